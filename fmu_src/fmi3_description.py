"""FMI 3.0 (Model Exchange and Co-Simulation): modelDescription.xml and sources/buildDescription.xml from the one
variable table.

`python build_fmu.py --fmi-version 3` calls in here; everything else (the C header model_variables.h, the
model's C code, compiling, zipping) is shared with FMI 2. The differences from FMI 2:

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
from xml.sax.saxutils import quoteattr

from fmu_src import MODEL_HEADERS, MODEL_SOURCES
from fmu_src.variables import DERIVATIVE, INDICATOR, INTEGER, REAL, STATE, Interface, Variable, c_literal

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


def _variable_xml(variable: Variable, vr: int, state_vr: int | None = None) -> str:
    attributes = [f"name={quoteattr(variable.name)}", f'valueReference="{vr}"']
    if variable.causality == "parameter":
        attributes += ['causality="parameter"', 'variability="fixed"']
        starts = " ".join(c_literal(variable, start) for start in variable.element_starts())
        attributes.append(f'start="{starts}"')
    else:
        variability = "continuous" if variable.type == REAL else "discrete"
        attributes += [f'causality="{variable.causality}"', f'variability="{variability}"', 'initial="calculated"']
    if state_vr is not None:
        attributes.append(f'derivative="{state_vr}"')
    attributes.append(f"description={quoteattr(variable.description)}")
    if variable.unit and variable.type == REAL:  # FMI 3 integers have no unit
        attributes.append(f"declaredType={quoteattr(variable.unit)}")
    if variable.enumeration:
        attributes.append(f"declaredType={quoteattr(variable.enumeration)}")
    if variable.minimum is not None:
        attributes.append(f'min="{_number(variable, variable.minimum)}"')
    if variable.maximum is not None:
        attributes.append(f'max="{_number(variable, variable.maximum)}"')
    tag = "Enumeration" if variable.enumeration else TYPE_NAMES[variable.type]
    head = f"    <{tag} " + "\n      ".join(attributes)
    if variable.size is None:
        return head + "/>"
    dimensions = "".join(f'\n      <Dimension start="{size}"/>' for size in (variable.shape or (variable.size,)))
    return f'{head}>{dimensions}\n    </{tag}>'


def generate_model_description(interface: Interface, identifier: str, token: str, scene, units: list[str]) -> str:
    """modelDescription.xml (FMI 3.0, Model Exchange and Co-Simulation) from the same table as the header and the
    FMI 2 XML."""
    variables_xml, outputs, initial_unknowns, derivatives, indicators = [], [], [], [], []
    references = interface.value_references
    for variable in interface.exposed:
        vr = references[variable.name]
        derivative_of = references[variable.derivative_of] if variable.role == DERIVATIVE else None
        variables_xml.append(_variable_xml(variable, vr, derivative_of))
        if variable.causality == "output":
            outputs.append(vr)
        if variable.causality == "output" or variable.role in (STATE, DERIVATIVE):
            initial_unknowns.append(vr)
        if variable.role == DERIVATIVE:  # in the order of the continuous states (lattice.h's layout)
            derivatives.append((interface.state_offsets()[variable.derivative_of], vr))
        if variable.role == INDICATOR:
            indicators.append(vr)
    time_vr = sum(v.count for v in interface.exposed)
    variables_xml.append(f'    <Float64 name="time" valueReference="{time_vr}" causality="independent" '
                         f'variability="continuous" declaredType="s" description="Simulation time"/>')
    units_xml = "\n".join(f"    <Unit name={quoteattr(unit)}/>" for unit in units)
    used = [unit for unit in units if unit == "s" or any(v.unit == unit and v.type == REAL for v in interface.exposed)]
    types_xml = "\n".join([f"    <Float64Type name={quoteattr(unit)} unit={quoteattr(unit)}/>" for unit in used] + [
        f"    <EnumerationType name={quoteattr(v.enumeration)}>\n" + "\n".join(
            f'      <Item name={quoteattr(name)} value="{value}" description={quoteattr(text)}/>'
            for value, (name, text) in enumerate(v.items)) + "\n    </EnumerationType>"
        for v in interface.exposed if v.enumeration])
    structure = "\n".join([f'    <Output valueReference="{vr}"/>' for vr in outputs]
                          + [f'    <ContinuousStateDerivative valueReference="{vr}"/>' for _, vr in sorted(derivatives)]
                          + [f'    <InitialUnknown valueReference="{vr}"/>' for vr in initial_unknowns]
                          + [f'    <EventIndicator valueReference="{vr}"/>' for vr in indicators])
    description = scene.description or f"{interface.rows} x {interface.cols} mass-spring lattice"
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription
  fmiVersion="3.0"
  modelName="{identifier}"
  instantiationToken="{token}"
  description={quoteattr(description)}
  generationTool="build_fmu.py"
  variableNamingConvention="structured">
  <ModelExchange
    modelIdentifier="{identifier}"
    needsCompletedIntegratorStep="true"
    canGetAndSetFMUState="true"
    canSerializeFMUState="true"/>
  <CoSimulation
    modelIdentifier="{identifier}"
    canHandleVariableCommunicationStepSize="true"
    canGetAndSetFMUState="true"
    canSerializeFMUState="true"
    hasEventMode="false"
    mightReturnEarlyFromDoStep="true"
    canReturnEarlyAfterIntermediateUpdate="false"
    providesIntermediateUpdate="false"/>
  <UnitDefinitions>
{units_xml}
  </UnitDefinitions>
  <TypeDefinitions>
{types_xml}
  </TypeDefinitions>
  <LogCategories>
    <Category name="logStatusError" description="Why a call failed"/>
    <Category name="logStatusDiscard" description="Why a step stopped early (peak_force_limit)"/>
  </LogCategories>
  <DefaultExperiment startTime="0" stopTime="{scene.horizon!r}" stepSize="{scene.communication_step!r}"/>
  <ModelVariables>
{chr(10).join(variables_xml)}
  </ModelVariables>
  <ModelStructure>
{structure}
  </ModelStructure>
</fmiModelDescription>
"""


def generate_build_description(identifier: str) -> str:
    """sources/buildDescription.xml: what `fmpy compile` (or any FMI 3 tool) compiles for another platform."""
    files = "\n".join(f'      <SourceFile name="{name}"/>' for name in C_SOURCES)
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiBuildDescription fmiVersion="3.0">
  <BuildConfiguration modelIdentifier="{identifier}">
    <SourceFileSet language="C99">
{files}
    </SourceFileSet>
  </BuildConfiguration>
</fmiBuildDescription>
"""
