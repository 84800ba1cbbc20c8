"""A design as an SSP archive (System Structure and Parameterization): the FMU, a system, a parameter set.

SSP is how FMI tools carry a parameter set with an FMU: `best_design.ssp` holds the FMU, an .ssd system with
one component bound to an .ssv parameter set (the order as material[1..C] and every other parameter the run
set), and the experiment (stop time, communication step). The .ssd carries the two vendor annotations the
tools that read it need: OMSimulator's system annotation (its C entry `oms_importFile` refuses a system
without one) and libcosim's algorithm (its fixed step). Tools that read it:

- libcosim: `CosimExecution.from_ssp_file("best_design.ssp")`;
- OMSimulator: `oms_importFile("best_design.ssp")` in C, or `OMSimulator.SSP("best_design.ssp").instantiate()`;
- FMPy: `fmpy.simulate_fmu(fmu, start_values=read_design_parameters("best_design.ssp"))` (FMPy's own
  `simulate_ssp` applies no parameter binding of a component).

    write_best_design_ssp("models/MassSpringLattice.fmu", {"material": order, "diagonal_rule": "mean"},
                          "results/best_design.ssp", stop_time=8.0, materials=table)
    read_design_parameters("results/best_design.ssp")   # {name: value}, every value checked against the FMU

Both directions check each value against the FMU's model description (type, min/max, integer, finite, an
enumeration's items), that the order is complete and a design of the FMU's design space (a permutation, an
arrangement, or any assignment when repeat_materials = 1), and refuse with one line naming the parameter.
The writer also refuses a design that a tool named above would silently run differently.
"""

from __future__ import annotations

import math
import numbers
import zipfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from fmpy import read_model_description
from lxml import etree

from builder.rendering import add_templates
from fmu_src.materials import FIELD_NAMES, MaterialTable

from .design import DesignSpace
from .simulation import REAL_TYPES, declared_parameters, enumeration_items, material_columns

SSD_NAME = "SystemStructure.ssd"  # what SSP readers open inside the archive
SSV_NAME = "resources/best_design.ssv"
SYSTEM = "best_design"
COMPONENT = "lattice"
REPEAT_PARAMETER = "repeat_materials"
MATERIAL_FIELDS = FIELD_NAMES  # the FMU's parameters per material
# OMSimulator imports a system only with its own annotation: a weakly coupled system ("oms-ma", the fixed-step
# master) with the communication step. The fixed-step master does not use the tolerance; OMSimulator writes
# its default there.
OMS = {
    "type": "org.openmodelica",
    "master": "oms-ma",
    "relative_tolerance": "0.0001",
    "namespace": "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd",
}
# libcosim reads its fixed step from this annotation of the default experiment (without it the caller of
# from_ssp_file must give one); other tools ignore it.
OSP = {"type": "com.opensimulationplatform", "namespace": "https://opensimulationplatform.com/SSP/1.0"}
NS = {
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
}
SSV_TYPES = ("Real", "Integer", "Boolean", "String", "Enumeration", "Binary")
INTEGER_TYPES = ("Integer", "Enumeration", "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64")


@dataclass(frozen=True)
class DesignParameter:
    """One entry of the parameter set: the FMU variable, its SSV type (Real or Integer), value, description."""

    name: str
    kind: str
    value: float | int
    description: str | None = None

    @property
    def text(self) -> str:
        return repr(float(self.value)) if self.kind == "Real" else str(int(self.value))


def _parameters_of(description) -> dict:
    return {v.name: v for v in description.modelVariables if v.causality == "parameter"}


def _unknown(name: str, description, source: str) -> ValueError:
    scalars: list[str] = []
    arrays: dict[str, int] = {}
    for known in _parameters_of(description):
        base, bracket, index = known.partition("[")
        if bracket:
            arrays[base] = max(arrays.get(base, 0), int(index.rstrip("]")))
        else:
            scalars.append(known)
    listed = ", ".join(sorted(scalars) + [f"{base}[1..{count}]" for base, count in arrays.items()])
    return ValueError(f"{source}: {name!r} is not a parameter of {description.modelName}; its parameters are {listed}")


def _checked_value(variable, description, kind: str, value, source: str) -> float | int:
    """``value`` as the FMU takes it, or a one-line ValueError naming the parameter and what it allows. ``kind``
    is the SSV type it comes as (an .ssv's text, parsed here as that type), or "item" for an enumeration item name
    given to the writer; the value itself is checked by the parameter's own type (``Parameter.value``)."""
    name = variable.name
    parameter = declared_parameters(description)[name]
    where = f"{source}: "
    if variable.type in REAL_TYPES:
        if kind != "Real":
            raise ValueError(f"{source}: {name} is a Real parameter of the FMU, but is given as {kind}")
        return parameter.value(value, where)
    if variable.type not in INTEGER_TYPES:
        raise ValueError(f"{source}: {name} is a {variable.type} parameter, which design files do not set")
    if kind == "Enumeration":  # libcosim aborts the process on an ssv:Enumeration
        raise ValueError(
            f"{source}: {name} is given as an ssv:Enumeration, which libcosim cannot read: give its code as ssv:Integer"
        )
    if kind not in ("Integer", "item"):
        raise ValueError(f"{source}: {name} is an integer parameter of the FMU, but is given as {kind}")
    if kind == "Integer" and isinstance(value, str):  # an ssv:Integer's text: decimal digits only
        try:
            value = int(value.strip(), 10)
        except ValueError:
            raise ValueError(f"{source}: {name} = {value!r} is not an integer") from None
    return parameter.value(value, where)


def _material_count(description) -> int:
    """M, the size of the FMU's material table: the largest material number material[1] allows."""
    first = declared_parameters(description).get("material[1]")
    high = None if first is None else first.maximum
    return int(high) if high is not None else material_columns(description)


def _check_design(description, values: Mapping[str, float | int], source: str) -> None:
    """Every material[j] given, and the order a design of the FMU's design space; else one line naming the
    parameter."""
    columns = material_columns(description)
    if columns == 0:  # a scene without materials (the two masses, the free lattice): no order to check
        return
    missing = [f"material[{j}]" for j in range(1, columns + 1) if f"material[{j}]" not in values]
    if missing:
        raise ValueError(f"{source}: {missing[0]} is missing: a design gives every material[j], j = 1..{columns}")
    order = [int(values[f"material[{j}]"]) for j in range(1, columns + 1)]
    repeat_variable = _parameters_of(description).get(REPEAT_PARAMETER)
    repeat = values.get(REPEAT_PARAMETER, 0 if repeat_variable is None else int(repeat_variable.start or 0))
    try:
        space = DesignSpace(columns, _material_count(description), bool(repeat))
    except ValueError as error:
        raise ValueError(f"{source}: {error} ({REPEAT_PARAMETER} = 1)") from None
    if not repeat:
        first_column: dict[int, int] = {}
        for j, material in enumerate(order, 1):
            if material in first_column:
                raise ValueError(
                    f"{source}: material[{j}] = {material} repeats material[{first_column[material]}]: "
                    f"each material at most once ({REPEAT_PARAMETER} = 0)"
                )
            first_column[material] = j
    try:
        space.check(order, "the order")
    except ValueError as error:
        raise ValueError(f"{source}: {error}") from None


def _tool_problem(description, entries: Sequence[DesignParameter]) -> str | None:
    """A parameter that a tool this module names would silently not apply (one line naming both), or None."""
    variables = _parameters_of(description)
    for entry in entries:
        variable = variables[entry.name]
        if description.fmiVersion.startswith("2.") and variable.type == "Enumeration":
            default = int(variable.start)
            if entry.value != default:
                items = {code: item for item, code in enumeration_items(description, entry.name).items()}
                return (
                    f"{entry.name} = {items.get(int(entry.value), entry.value)}: libcosim ignores FMI 2 Enumeration "
                    f"parameters and would run {entry.name} = {items.get(default, default)}; this FMU cannot carry "
                    f"that design to libcosim (rebuild it with {entry.name} settable as an Integer)"
                )
    return None


def _table_start_values(description, field: str, count: int) -> list[float] | None:
    variables = _parameters_of(description)
    if f"{field}[1]" in variables:
        return [float(variables[f"{field}[{m}]"].start) for m in range(1, count + 1)]
    if field in variables:  # an FMI 3 array
        return [float(text) for text in str(variables[field].start).split()]
    return None


def _check_table(description, materials: MaterialTable, values: Mapping[str, float | int]) -> None:
    """The names describe the FMU's table: the same size and, parameter by parameter, the same values."""
    count = _material_count(description)
    if len(materials) != count:
        raise ValueError(f"materials: the table has {len(materials)} materials, the FMU's has {count}")
    for field in MATERIAL_FIELDS:
        starts = _table_start_values(description, field, count)
        if starts is None:
            continue
        for m, (table_value, start) in enumerate(zip(materials.column(field), starts), 1):
            used = float(values.get(f"{field}[{m}]", start))
            if not math.isclose(table_value, used, rel_tol=1e-12, abs_tol=0.0):
                raise ValueError(
                    f"materials: {field} of material {m} ({materials.name_of(m)!r}) is {table_value!r} "
                    f"in the table, but {field}[{m}] = {used!r} in the design: the names would "
                    "describe another table"
                )


def design_parameters(
    fmu_path: str | Path, parameters: Mapping, materials: MaterialTable | None = None
) -> list[DesignParameter]:
    """The parameter set of a design, each value checked against the FMU: a sequence expands to name[1..n]
    (``material`` is the order), an enumeration may be given by item name ("mean") or code. With ``materials``
    (the MaterialTable the FMU was built with) each material[j] says the name of the material it holds."""
    description = read_model_description(str(fmu_path))
    known = _parameters_of(description)
    entries: list[tuple[str, object]] = []
    for name, value in parameters.items():
        if isinstance(value, Sequence) and not isinstance(value, str):
            entries += [(f"{name}[{index}]", element) for index, element in enumerate(value, start=1)]
        else:
            entries.append((name, value))
    values: dict[str, float | int] = {}
    for name, value in entries:
        variable = known.get(name)
        if variable is None:
            raise _unknown(name, description, "parameters")
        if name in values:
            raise ValueError(f"parameters: {name} is given twice")
        if isinstance(value, str) and not enumeration_items(description, name):  # text is for item names only
            raise ValueError(
                f"parameters: {name} = {value!r} is not a {'number' if variable.type in REAL_TYPES else 'integer'}"
            )
        kind = "Real" if variable.type in REAL_TYPES else "item" if isinstance(value, str) else "Integer"
        values[name] = _checked_value(variable, description, kind, value, "parameters")
    _check_design(description, values, "parameters")
    if materials is not None:
        _check_table(description, materials, values)
    result = []
    for name, value in values.items():
        note = None
        items = {code: item for item, code in enumeration_items(description, name).items()}
        if items:
            note = f"{name} = {items[int(value)]}"
        elif materials is not None and name.startswith("material["):
            note = f"column {name[len('material[') : -1]}: material {value} ({materials.name_of(int(value))})"
        result.append(DesignParameter(name, "Real" if known[name].type in REAL_TYPES else "Integer", value, note))
    return result


def design_refusal(fmu_path: str | Path, parameters: Mapping, materials: MaterialTable | None = None) -> str | None:
    """Why write_best_design_ssp would refuse this design (one line), or None: for a study to say so before
    it runs (with a valid order, say its design space's baseline: a tool's refusal does not depend on the
    order), and for its report to say instead of the file."""
    try:
        entries = design_parameters(fmu_path, parameters, materials)
    except ValueError as error:
        return str(error)
    return _tool_problem(read_model_description(str(fmu_path)), entries)


def write_best_design_ssp(
    fmu_path: str | Path,
    parameters: Mapping,
    out_path: str | Path,
    *,
    stop_time: float,
    step_size: float = 0.01,
    materials: MaterialTable | None = None,
) -> Path:
    """Writes `out_path` (.ssp): the FMU, `parameters` as an .ssv bound to it in the .ssd, the experiment.
    Refuses (ValueError, one line) a value the FMU does not allow, an incomplete or invalid order, and a
    parameter a tool named in this module's docstring would silently not apply."""
    fmu_path, out_path = Path(fmu_path), Path(out_path)
    for name, value in (("stop_time", stop_time), ("step_size", step_size)):
        if isinstance(value, bool) or not isinstance(value, numbers.Real) or not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name} = {value!r} is not allowed: give a finite number of seconds > 0")
    description = read_model_description(str(fmu_path))
    entries = design_parameters(fmu_path, parameters, materials)
    problem = _tool_problem(description, entries)
    if problem is not None:
        raise ValueError(problem)
    fmu_member = f"resources/{fmu_path.name}"
    connectors = [
        {"name": v.name, "kind": "Real" if v.type in REAL_TYPES else "Integer"}
        for v in description.modelVariables
        if v.causality == "output" and v.type in REAL_TYPES + INTEGER_TYPES and not getattr(v, "dimensions", None)
    ]
    ssd = (
        add_templates("orchestrator")
        .get_template("ssp_system_structure.ssd")
        .render(
            system=SYSTEM,
            component=COMPONENT,
            fmu_member=fmu_member,
            connectors=connectors,
            parameter_set=SSV_NAME,
            description="A material order found by the lattice study, as a parameter set of the lattice FMU",
            stop_time=repr(float(stop_time)),
            step_size=repr(float(step_size)),
            oms=OMS,
            osp=OSP,
        )
    )
    ssv = add_templates("orchestrator").get_template("ssp_parameter_set.ssv").render(name=SYSTEM, parameters=entries)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    partial = out_path.with_name(out_path.name + ".partial")
    try:
        with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as archive:
            archive.writestr(SSD_NAME, ssd)
            archive.writestr(SSV_NAME, ssv)
            archive.write(fmu_path, fmu_member)
        read_design_parameters(partial)  # what is written is what the reader accepts
        partial.replace(out_path)
    finally:
        partial.unlink(missing_ok=True)
    return out_path


def _parse(archive: zipfile.ZipFile, member: str, source: str):
    try:
        with archive.open(member) as handle:
            return etree.parse(handle, etree.XMLParser(resolve_entities=False, no_network=True)).getroot()
    except KeyError:
        raise ValueError(f"{source}: {member} is not in the archive") from None
    except etree.XMLSyntaxError as error:
        raise ValueError(f"{source}: {member} is not well-formed XML ({error})") from None


def _bound_parameters(archive: zipfile.ZipFile, component, source: str):
    """(parameter set name, prefix, ssv:Parameter element) for each parameter bound to ``component``."""
    for binding in component.findall("ssd:ParameterBindings/ssd:ParameterBinding", NS):
        prefix = binding.get("prefix") or ""
        member = binding.get("source")
        if member is not None:
            sets = [_parse(archive, member, source)]
            if sets[0].tag != f"{{{NS['ssv']}}}ParameterSet":
                raise ValueError(f"{source}: {member} is not an SSP parameter set (ssv:ParameterSet)")
        else:
            sets = binding.findall("ssd:ParameterValues/ssv:ParameterSet", NS)
        for parameter_set in sets:
            for parameter in parameter_set.findall("ssv:Parameters/ssv:Parameter", NS):
                yield parameter_set.get("name"), prefix, parameter


def read_design_parameters(ssp_path: str | Path) -> dict[str, float | int]:
    """The parameter values an .ssp binds to its FMU, each checked against the FMU's model description, and
    the order checked as a design; a one-line ValueError naming the parameter otherwise (rather than let a
    tool ignore it, or abort on the FMU's refusal)."""
    from fmpy.ssp.ssd import read_ssd

    ssp_path = Path(ssp_path)
    source = ssp_path.name
    try:
        archive = zipfile.ZipFile(ssp_path)
    except (OSError, zipfile.BadZipFile) as error:
        raise ValueError(f"{source}: not an SSP archive ({error})") from None
    with archive:
        root = _parse(archive, SSD_NAME, source)
        components = root.findall("ssd:System/ssd:Elements/ssd:Component", NS)
        if len(components) != 1 or root.findall("ssd:System/ssd:Elements/ssd:System", NS):
            raise ValueError(f"{source}: the system holds {len(components)} components; a design holds one FMU")
        (component,) = components
        member = component.get("source") or ""
        try:
            with archive.open(member) as fmu:
                description = read_model_description(fmu)
        except KeyError:
            raise ValueError(
                f"{source}: component {component.get('name')!r} names {member!r}, which is not in the archive"
            ) from None
        except Exception as error:  # fmpy's reader raises bare Exceptions
            raise ValueError(f"{source}: {member} is not an FMU ({str(error).splitlines()[0]})") from None
        known = _parameters_of(description)
        values: dict[str, float | int] = {}
        for set_name, prefix, parameter in _bound_parameters(archive, component, source):
            where = f"{source}: parameter set {set_name!r}"
            name = parameter.get("name") or ""
            if not name.startswith(prefix):
                raise ValueError(f"{where}: {name!r} does not start with the binding's prefix {prefix!r}")
            name = name[len(prefix) :]
            if name not in known:
                raise _unknown(name, description, where)
            typed = [child for child in parameter if etree.QName(child).localname in SSV_TYPES]
            if len(typed) != 1:
                raise ValueError(f"{where}: {name} has {len(typed)} values; a parameter has one")
            if name in values:
                raise ValueError(f"{where}: {name} is given twice")
            kind = etree.QName(typed[0]).localname
            text = typed[0].get("value")
            if text is None:
                raise ValueError(f"{where}: {name} has no value")
            values[name] = _checked_value(known[name], description, kind, text, where)
        _check_design(description, values, source)
    try:
        read_ssd(str(ssp_path))  # the SSP 1.0 schemas, for the .ssd and each .ssv
    except Exception as error:  # fmpy raises a bare Exception with the validator's log
        raise ValueError(f"{source}: not a valid SSP 1.0 archive: {str(error).splitlines()[-1]}") from None
    return values


__all__ = [
    "COMPONENT",
    "DesignParameter",
    "SSD_NAME",
    "SSV_NAME",
    "SYSTEM",
    "design_parameters",
    "design_refusal",
    "read_design_parameters",
    "write_best_design_ssp",
]
