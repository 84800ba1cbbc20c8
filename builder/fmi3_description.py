"""FMI 3.0 (Model Exchange and Co-Simulation): modelDescription.xml and sources/buildDescription.xml from the one
variable table, through the templates builder/templates/fmi3_*.xml.

`builder.build.build_fmu(..., fmi_version=3)` calls in here; everything else (the C header model_variables.h,
the model's C code, compiling, zipping) is shared with FMI 2. The differences from FMI 2:

- a parameter array (`material`, the material table's `k`, `c`, ..., `mass`, `damping_exponent`) is one FMI 3
  array of fixed length (`<Dimension start="C"/>` or `start="M"`), set and read with one value reference and
  nValues its length; every other array (the states `ux`, their derivatives, the event indicators) stays a list
  of scalars with FMI 2's names (`ux[1,1]`, `der(ux[1,1])`), as Model Exchange importers expect states. Built
  with `arrays=False` (build_fmu.py --fmi3-scalars) the parameter arrays too are scalars with FMI 2's names
  (`material[1]` ...), for importers that set no FMI 3 array (OMSimulator 3, fmi-sim 0.7).
- a value reference is the variable's 1-based position in <ModelVariables>, `time` last: an importer that reads
  a derivative's `derivative` attribute (the state's value reference) as an index into the variable list, as
  OMSimulator 3 does, finds the state there. The glue maps it onto the model's value references through the
  generated header fmi3_variables.h (VARIABLE_MAP_HEADER).
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
from dataclasses import dataclass
from pathlib import Path

from builder.fmi2_description import enumeration_types, lattice_size, range_attributes
from builder.rendering import default_experiment, model_summary, render
from builder.sources import SourceTree
from fmu_src.variables import (
    DERIVATIVE,
    INDICATOR,
    INTEGER,
    LOG_CATEGORIES,
    REAL,
    STATE,
    UNITS,
    Interface,
    Variable,
    c_literal,
)
from scenes import SIZE_ANNOTATION

TYPE_NAMES = {REAL: "Float64", INTEGER: "Int32"}  # an Integer with an enumeration type is an Enumeration (Int64)
# A Float64 variable gets its unit through a declared type named after the unit (<Float64Type name="N.s/m"
# unit="N.s/m"/>), not through a unit attribute: both are FMI 3.0, but fmi-sim 0.7 (Rust) refuses a unit
# attribute on a variable.
# FMI 3 value reference = the 1-based position in <ModelVariables>
VR_OFFSET = 1
VARIABLE_MAP_HEADER = "fmi3_variables.h"  # the glue's map of FMI 3 value references onto the model's
OUTPUT_SUFFIX = "-fmi3"  # models/MassSpringLattice-fmi3.fmu beside the FMI 2 models/MassSpringLattice.fmu


def is_fmi3_array(variable: Variable) -> bool:
    """A parameter array (material, the material table's columns): one FMI 3 array. The other arrays (states,
    derivatives, indicators) are declared element by element."""
    return variable.causality == "parameter" and variable.size is not None


@dataclass(frozen=True)
class DeclaredVariable:
    """One entry of FMI 3's <ModelVariables>: a whole parameter array or one scalar (an element of any other
    array), with the model's value references it moves."""

    variable: Variable
    name: str
    model_reference: int  # the model's value reference of its (first) value
    length: int  # how many values: the array's length, or 1
    element: int  # which element of `variable` a scalar is (0 for a whole array)
    starts: tuple  # one start per value
    is_array: bool  # declared with a <Dimension>, even of length 1


def declared_variables(interface: Interface, arrays: bool = True) -> list[DeclaredVariable]:
    """<ModelVariables> in order (without `time`): the FMI 3 value reference of entry i is i + VR_OFFSET; with
    `arrays` False every variable is declared element by element."""
    declared = []
    for variable in interface.exposed:
        first = interface.value_references[variable.name]
        if arrays and is_fmi3_array(variable):
            declared.append(
                DeclaredVariable(
                    variable, variable.name, first, variable.count, 0, tuple(variable.element_starts()), True
                )
            )
            continue
        for offset, (name, start) in enumerate(zip(variable.element_names(), variable.element_starts())):
            declared.append(DeclaredVariable(variable, name, first + offset, 1, offset, (start,), False))
    return declared


def generate_variable_map(interface: Interface, arrays: bool = True) -> str:
    """fmi3_variables.h: which model value references each FMI 3 array moves; every other FMI 3 value reference
    is one scalar, the model's next one (fmi3/fmi3_glue.c, model_range)."""
    declared = declared_variables(interface, arrays)
    entries = [
        f"    {{{position + VR_OFFSET}u, {entry.model_reference}u, {entry.length}u}}, /* {entry.name} */"
        for position, entry in enumerate(declared)
        if entry.is_array
    ]
    lines = [
        "/* Generated by builder/fmi3_description.py from fmu_src/variables.py: do not edit. */",
        "#ifndef FMI3_VARIABLES_H",
        "#define FMI3_VARIABLES_H",
        "",
        "/* An FMI 3 array: its value reference, the model's value reference of its first element, its length. */",
        "typedef struct {",
        "    unsigned int reference, first, length;",
        "} Fmi3Array;",
        "",
        f"#define FMI3_VARIABLE_COUNT {len(declared)}u /* value references VR_OFFSET ..., then time */",
        f"#define FMI3_ARRAY_COUNT {len(entries)}u",
        "/* in value-reference order, ended by an entry of length 0 */",
        "static const Fmi3Array FMI3_ARRAYS[FMI3_ARRAY_COUNT + 1u] = {",
        *entries,
        "    {0u, 0u, 0u}",
        "};",
        "",
        "#endif",
        "",
    ]
    return "\n".join(lines)


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


def instantiation_token(fmi2_guid: str, files: list[Path], variable_map: str = "") -> str:
    """The FMI 2 GUID (variables, model sources) folded with the FMI 3 build's files (glue and model) and its
    variable map (arrays or scalars: another layout of value references): changes when any of them does."""
    digest = hashlib.sha256(fmi2_guid.encode() + variable_map.encode())
    for path in files:
        digest.update(path.read_bytes())
    return "{" + str(uuid.UUID(bytes=digest.digest()[:16], version=5)) + "}"


def model_variables(interface: Interface, arrays: bool = True) -> tuple[list[dict], list[tuple[str, int, str | None]]]:
    """<ModelVariables> (declared_variables: each parameter array one variable with a <Dimension>, every other
    variable as scalars with FMI 2's names), value reference = the 1-based position, then `time`; and
    <ModelStructure>'s elements (Output, ContinuousStateDerivative in the order of the continuous states,
    InitialUnknown, EventIndicator) with their value references and, for an Output, the value references of the
    inputs it depends on directly (space-separated; None: no attribute)."""
    variables: list[dict] = []
    outputs: list[tuple[int, str]] = []  # an output's value reference, those of the inputs it depends on
    derivatives: list[tuple[int, int]] = []  # a derivative's state offset, its value reference
    initial_unknowns: list[int] = []
    indicators: list[int] = []
    state_offsets = interface.state_offsets()
    declared = declared_variables(interface, arrays)
    first_reference: dict[str, int] = {}  # the FMI 3 value reference of each variable's first entry
    for position, entry in enumerate(declared):
        first_reference.setdefault(entry.variable.name, position + VR_OFFSET)
    for position, entry in enumerate(declared):
        variable, vr = entry.variable, position + VR_OFFSET
        attributes = [("name", entry.name), ("valueReference", str(vr))]
        if variable.causality in ("parameter", "input"):
            start = " ".join(c_literal(variable, value) for value in entry.starts)
        if variable.causality == "parameter":
            attributes += [("causality", "parameter"), ("variability", "fixed"), ("start", start)]
        elif variable.causality == "input":
            attributes += [("causality", "input"), ("variability", "continuous"), ("start", start)]
        else:
            variability = "continuous" if variable.type == REAL else "discrete"
            attributes += [("causality", variable.causality), ("variability", variability), ("initial", "calculated")]
        if variable.role == DERIVATIVE:
            state = variable.derivative_of
            if state is None:
                raise ValueError(f"variable {variable.name}: a derivative must name its state (derivative_of)")
            attributes.append(("derivative", str(first_reference[state] + entry.element)))
            derivatives.append((state_offsets[state] + entry.element, vr))
        attributes.append(("description", variable.description))
        if variable.unit and variable.type == REAL:  # FMI 3 integers have no unit
            attributes.append(("declaredType", variable.unit))
        if variable.enumeration:
            attributes.append(("declaredType", variable.enumeration))
        attributes += range_attributes(variable)
        variables.append(
            {
                "tag": "Enumeration" if variable.enumeration else TYPE_NAMES[variable.type],
                "attributes": attributes,
                "dimensions": [entry.length] if entry.is_array else [],
            }
        )
        if variable.causality == "output":
            outputs.append(
                (
                    vr,
                    " ".join(
                        str(first_reference[name])
                        for name in sorted(variable.depends_on, key=first_reference.__getitem__)
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
            "dimensions": [],
        }
    )
    structure: list[tuple[str, int, str | None]] = [("Output", vr, dependencies) for vr, dependencies in outputs]
    structure += [("ContinuousStateDerivative", vr, None) for _, vr in sorted(derivatives)]
    structure += [("InitialUnknown", vr, None) for vr in initial_unknowns]
    structure += [("EventIndicator", vr, None) for vr in indicators]
    return variables, structure


def generate_model_description(interface: Interface, identifier: str, token: str, scene, arrays: bool = True) -> str:
    """modelDescription.xml (FMI 3.0, Model Exchange and Co-Simulation) from the same table as the header and the
    FMI 2 XML; `arrays` False declares the parameter arrays element by element."""
    variables, structure = model_variables(interface, arrays)
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
