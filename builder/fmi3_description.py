"""FMI 3.0 (Model Exchange and Co-Simulation): modelDescription.xml and sources/buildDescription.xml from the one
variable table, through the templates builder/templates/fmi3_*.xml.

`builder.build.build_fmu(..., fmi_version=3)` calls in here; everything else (the C header model_variables.h,
the model's C code, compiling, zipping) is shared with FMI 2. The differences from FMI 2:

- every variable is a scalar with FMI 2's name (`material[1]` ... `material[C]`, `ux[1,1]`, `der(ux[1,1])`):
  importers without FMI 3 arrays (OMSimulator 3) set and read them all, and one parameter dict serves both.
- a value reference is the variable's 1-based position in <ModelVariables> (FMI 2's plus VR_OFFSET), `time`
  last: an importer that reads a derivative's `derivative` attribute (the state's value reference) as an index
  into the variable list, as OMSimulator 3 does, finds the state there.
- Real becomes Float64, Integer Int32, and an enumeration parameter is an Enumeration (moved as Int64).
- a Float64 variable's unit comes from a declared type in <TypeDefinitions>, named after the unit.
- FMI 3 wants exactly one independent variable: `time` (fmi3/fmi3_glue.c answers it from the model's time).
- the sources are listed in sources/buildDescription.xml, not in modelDescription.xml.
- binaries go to `binaries/<architecture>-<system>/` (e.g. x86_64-linux).
"""

from __future__ import annotations

import hashlib
import platform
import uuid
from pathlib import Path

from builder.fmi2_description import enumeration_types, lattice_size, range_attributes
from builder.rendering import default_experiment, model_summary, render
from builder.sources import SourceTree
from fmu_src.variables import DERIVATIVE, INDICATOR, INTEGER, LOG_CATEGORIES, REAL, STATE, UNITS, Interface, c_literal
from scenes import SIZE_ANNOTATION

TYPE_NAMES = {REAL: "Float64", INTEGER: "Int32"}  # an Integer with an enumeration type is an Enumeration (Int64)
# A Float64 variable gets its unit through a declared type named after the unit (<Float64Type name="N.s/m"
# unit="N.s/m"/>), not through a unit attribute: both are FMI 3.0, but fmi-sim 0.7 (Rust) refuses a unit
# attribute on a variable.
# FMI 3 value reference = the model's (FMI 2's) + VR_OFFSET: the 1-based position in <ModelVariables>
VR_OFFSET = 1
OUTPUT_SUFFIX = "-fmi3"  # models/MassSpringLattice-fmi3.fmu beside the FMI 2 models/MassSpringLattice.fmu


def platform_folder() -> tuple[str, str]:
    """FMI 3 binaries folder (the platform tuple) and shared-library suffix for this machine."""
    machine = platform.machine().lower()
    architecture = {"amd64": "x86_64", "x86_64": "x86_64", "arm64": "aarch64", "aarch64": "aarch64"}.get(machine)
    system = {"Linux": ("linux", ".so"), "Darwin": ("darwin", ".dylib"), "Windows": ("windows", ".dll")}.get(
        platform.system()
    )
    if architecture is None or system is None:
        raise RuntimeError(
            f"unsupported platform {platform.system()} {platform.machine()}: build from the FMU's "
            f"sources with `fmpy compile`"
        )
    return f"{architecture}-{system[0]}", system[1]


def instantiation_token(fmi2_guid: str, files: list[Path]) -> str:
    """The FMI 2 GUID (variables, model sources) folded with the FMI 3 build's files (glue and model): changes
    when any of them does."""
    digest = hashlib.sha256(fmi2_guid.encode())
    for path in files:
        digest.update(path.read_bytes())
    return "{" + str(uuid.UUID(bytes=digest.digest()[:16], version=5)) + "}"


def model_variables(interface: Interface) -> tuple[list[dict], list[tuple[str, int, str | None]]]:
    """Every variable as a scalar (FMI 2's elements and names), value reference = its 1-based position in
    <ModelVariables>, then `time`; and <ModelStructure>'s elements (Output, ContinuousStateDerivative in the
    order of the continuous states, InitialUnknown, EventIndicator) with their value references and, for an
    Output, the value references of the inputs it depends on directly (space-separated; None: no attribute)."""
    variables, outputs, initial_unknowns, derivatives, indicators = [], [], [], [], []
    references, state_offsets = interface.value_references, interface.state_offsets()
    for variable in interface.exposed:
        first = references[variable.name] + VR_OFFSET
        for offset, (name, start) in enumerate(zip(variable.element_names(), variable.element_starts())):
            vr = first + offset
            attributes = [("name", name), ("valueReference", str(vr))]
            if variable.causality == "parameter":
                attributes += [
                    ("causality", "parameter"),
                    ("variability", "fixed"),
                    ("start", c_literal(variable, start)),
                ]
            elif variable.causality == "input":
                attributes += [
                    ("causality", "input"),
                    ("variability", "continuous"),
                    ("start", c_literal(variable, start)),
                ]
            else:
                variability = "continuous" if variable.type == REAL else "discrete"
                attributes += [
                    ("causality", variable.causality),
                    ("variability", variability),
                    ("initial", "calculated"),
                ]
            if variable.role == DERIVATIVE:
                attributes.append(("derivative", str(references[variable.derivative_of] + VR_OFFSET + offset)))
                derivatives.append((state_offsets[variable.derivative_of] + offset, vr))
            attributes.append(("description", variable.description))
            if variable.unit and variable.type == REAL:  # FMI 3 integers have no unit
                attributes.append(("declaredType", variable.unit))
            if variable.enumeration:
                attributes.append(("declaredType", variable.enumeration))
            attributes += range_attributes(variable)
            variables.append(
                {"tag": "Enumeration" if variable.enumeration else TYPE_NAMES[variable.type], "attributes": attributes}
            )
            if variable.causality == "output":
                outputs.append(
                    (
                        vr,
                        " ".join(
                            str(references[name] + VR_OFFSET)
                            for name in sorted(variable.depends_on, key=references.get)
                        ),
                    )
                )
            if variable.causality == "output" or variable.role in (STATE, DERIVATIVE):
                initial_unknowns.append(vr)
            if variable.role == INDICATOR:
                indicators.append(vr)
    time_vr = len(variables) + VR_OFFSET
    variables.append(
        {
            "tag": "Float64",
            "attributes": [
                ("name", "time"),
                ("valueReference", str(time_vr)),
                ("causality", "independent"),
                ("variability", "continuous"),
                ("declaredType", "s"),
                ("description", "Simulation time"),
            ],
        }
    )
    structure = (
        [("Output", vr, dependencies) for vr, dependencies in outputs]
        + [("ContinuousStateDerivative", vr, None) for _, vr in sorted(derivatives)]
        + [("InitialUnknown", vr, None) for vr in initial_unknowns]
        + [("EventIndicator", vr, None) for vr in indicators]
    )
    return variables, structure


def generate_model_description(interface: Interface, identifier: str, token: str, scene) -> str:
    """modelDescription.xml (FMI 3.0, Model Exchange and Co-Simulation) from the same table as the header and the
    FMI 2 XML."""
    variables, structure = model_variables(interface)
    used = [unit for unit in UNITS if unit == "s" or any(v.unit == unit and v.type == REAL for v in interface.exposed)]
    return render(
        "fmi3_model_description.xml",
        identifier=identifier,
        token=token,
        description=model_summary(interface, scene),
        units=UNITS,
        unit_types=used,
        enumerations=enumeration_types(interface),
        log_categories=LOG_CATEGORIES,
        experiment=default_experiment(scene),
        variables=variables,
        structure=structure,
        annotation_tool=SIZE_ANNOTATION,
        lattice_size=lattice_size(interface),
    )


def generate_build_description(identifier: str, sources: list[str] | None = None) -> str:
    """sources/buildDescription.xml: what `fmpy compile` (or any FMI 3 tool) compiles for another platform;
    `sources` are the C files in the FMU's sources/ (default: the lattice's)."""
    sources = sources if sources is not None else SourceTree(fmi_version=3).source_names()
    return render("fmi3_build_description.xml", identifier=identifier, sources=sources)
