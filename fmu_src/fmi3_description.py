"""FMI 3.0 (Model Exchange and Co-Simulation): modelDescription.xml and sources/buildDescription.xml from the one
variable table, through the templates fmu_src/templates/fmi3_*.xml.

`fmu_src.build.build_fmu(..., fmi_version=3)` calls in here; everything else (the C header model_variables.h,
the model's C code, compiling, zipping) is shared with FMI 2. The differences from FMI 2:

- an array is one variable: `material` is an Int32 variable with `<Dimension start="11"/>` and the value
  reference of its first element (the states `ux`, ... are 11 x 11 arrays, `der(ux)` their derivatives); Real becomes Float64 and Integer becomes Int32. Scalars keep their FMI 2
  names and value references, so a caller that knows one FMU knows the other.
- a Float64 variable's unit comes from a declared type in <TypeDefinitions>, named after the unit.
- FMI 3 wants exactly one independent variable: `time`, with the first value reference past the model's
  variables (fmi3/fmi3_glue.c answers it from the model's time).
- the sources are listed in sources/buildDescription.xml, not in modelDescription.xml.
- binaries go to `binaries/<architecture>-<system>/` (e.g. x86_64-linux).
"""
from __future__ import annotations

import hashlib
import platform
import uuid
from pathlib import Path

from fmu_src import MODEL_HEADERS, MODEL_SOURCES
from fmu_src.fmi2_description import enumeration_types
from fmu_src.rendering import default_experiment, model_summary, render
from fmu_src.variables import (DERIVATIVE, INDICATOR, INTEGER, LOG_CATEGORIES, REAL, STATE, UNITS, Interface,
                               Variable, c_literal)

C_SOURCES = ["fmi3/fmi3_glue.c"] + MODEL_SOURCES
C_HEADERS = ["include/fmi3Functions.h", "include/fmi3FunctionTypes.h", "include/fmi3PlatformTypes.h"] + MODEL_HEADERS
TYPE_NAMES = {REAL: "Float64", INTEGER: "Int32"}  # an Integer with an enumeration type is an Enumeration (Int64)
# A Float64 variable gets its unit through a declared type named after the unit (<Float64Type name="N.s/m"
# unit="N.s/m"/>), not through a unit attribute: both are FMI 3.0, but fmi-sim 0.7 (Rust) refuses a unit
# attribute on a variable.
OUTPUT_SUFFIX = "-fmi3"  # models/MassSpringLattice-fmi3.fmu beside the FMI 2 models/MassSpringLattice.fmu


def platform_folder() -> tuple[str, str]:
    """FMI 3 binaries folder (the platform tuple) and shared-library suffix for this machine."""
    machine = platform.machine().lower()
    architecture = {"amd64": "x86_64", "x86_64": "x86_64", "arm64": "aarch64", "aarch64": "aarch64"}.get(machine)
    system = {"Linux": ("linux", ".so"), "Darwin": ("darwin", ".dylib"), "Windows": ("windows", ".dll")}.get(
        platform.system())
    if architecture is None or system is None:
        raise RuntimeError(f"unsupported platform {platform.system()} {platform.machine()}: build from the FMU's "
                           f"sources with `fmpy compile`")
    return f"{architecture}-{system[0]}", system[1]


def instantiation_token(fmi2_guid: str, source_dir: Path) -> str:
    """The FMI 2 GUID (variables, model sources) folded with the FMI 3 glue: changes when any of them does."""
    digest = hashlib.sha256(fmi2_guid.encode())
    for name in C_SOURCES + C_HEADERS:
        digest.update((source_dir / name).read_bytes())
    return "{" + str(uuid.UUID(bytes=digest.digest()[:16], version=5)) + "}"


def _number(variable: Variable, value) -> str:
    return str(int(value)) if variable.type == INTEGER else repr(float(value))


def model_variable(variable: Variable, vr: int, state_vr: int | None = None) -> dict:
    """One FMI 3 variable: its element (Float64, Int32, Enumeration), attributes in order, dimensions."""
    attributes = [("name", variable.name), ("valueReference", str(vr))]
    if variable.causality == "parameter":
        attributes += [("causality", "parameter"), ("variability", "fixed"),
                       ("start", " ".join(c_literal(variable, start) for start in variable.element_starts()))]
    else:
        variability = "continuous" if variable.type == REAL else "discrete"
        attributes += [("causality", variable.causality), ("variability", variability), ("initial", "calculated")]
    if state_vr is not None:
        attributes.append(("derivative", str(state_vr)))
    attributes.append(("description", variable.description))
    if variable.unit and variable.type == REAL:  # FMI 3 integers have no unit
        attributes.append(("declaredType", variable.unit))
    if variable.enumeration:
        attributes.append(("declaredType", variable.enumeration))
    if variable.minimum is not None:
        attributes.append(("min", _number(variable, variable.minimum)))
    if variable.maximum is not None:
        attributes.append(("max", _number(variable, variable.maximum)))
    dimensions = [] if variable.size is None else list(variable.shape or (variable.size,))
    return {"tag": "Enumeration" if variable.enumeration else TYPE_NAMES[variable.type], "attributes": attributes,
            "dimensions": dimensions}


def generate_model_description(interface: Interface, identifier: str, token: str, scene) -> str:
    """modelDescription.xml (FMI 3.0, Model Exchange and Co-Simulation) from the same table as the header and the
    FMI 2 XML."""
    variables, outputs, initial_unknowns, derivatives, indicators = [], [], [], [], []
    references = interface.value_references
    for variable in interface.exposed:
        vr = references[variable.name]
        derivative_of = references[variable.derivative_of] if variable.role == DERIVATIVE else None
        variables.append(model_variable(variable, vr, derivative_of))
        if variable.causality == "output":
            outputs.append(vr)
        if variable.causality == "output" or variable.role in (STATE, DERIVATIVE):
            initial_unknowns.append(vr)
        if variable.role == DERIVATIVE:  # in the order of the continuous states (lattice.h's layout)
            derivatives.append((interface.state_offsets()[variable.derivative_of], vr))
        if variable.role == INDICATOR:
            indicators.append(vr)
    time_vr = sum(v.count for v in interface.exposed)
    variables.append({"tag": "Float64", "dimensions": [], "attributes": [
        ("name", "time"), ("valueReference", str(time_vr)), ("causality", "independent"),
        ("variability", "continuous"), ("declaredType", "s"), ("description", "Simulation time")]})
    used = [unit for unit in UNITS if unit == "s" or any(v.unit == unit and v.type == REAL for v in interface.exposed)]
    structure = ([("Output", vr) for vr in outputs]
                 + [("ContinuousStateDerivative", vr) for _, vr in sorted(derivatives)]
                 + [("InitialUnknown", vr) for vr in initial_unknowns]
                 + [("EventIndicator", vr) for vr in indicators])
    return render("fmi3_model_description.xml", identifier=identifier, token=token,
                  description=model_summary(interface, scene), units=UNITS, unit_types=used,
                  enumerations=enumeration_types(interface), log_categories=LOG_CATEGORIES,
                  experiment=default_experiment(scene), variables=variables, structure=structure)


def generate_build_description(identifier: str) -> str:
    """sources/buildDescription.xml: what `fmpy compile` (or any FMI 3 tool) compiles for another platform."""
    return render("fmi3_build_description.xml", identifier=identifier, sources=C_SOURCES)
