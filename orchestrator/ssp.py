"""A design as an SSP archive (System Structure and Parameterization): the FMU, a system, a parameter set.

SSP is how FMI tools carry a parameter set with an FMU: `best_design.ssp` holds the FMU, an .ssd system with
one component bound to an .ssv parameter set (the order as material[1..C] and the scene's non-default
parameters), and the experiment (stop time, communication step). libcosim runs it directly
(`CosimExecution.from_ssp_file`), FMPy reads it (`fmpy.ssp.ssd.read_ssd`, `read_ssv`).

    write_best_design_ssp("models/MassSpringLattice.fmu", {"material": order, "diagonal_rule": "mean"},
                          "results/best_design.ssp", stop_time=8.0)
    read_design_parameters("results/best_design.ssp")   # {name: value}; refuses names the FMU lacks
"""
from __future__ import annotations

import zipfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from xml.sax.saxutils import quoteattr

from fmpy import read_model_description

SSD_NAME = "SystemStructure.ssd"  # what SSP readers open inside the archive
SSV_NAME = "resources/best_design.ssv"
COMPONENT = "lattice"
NAMESPACES = ('xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" '
              'xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" '
              'xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"')
# libcosim reads its fixed step from this annotation of the default experiment (without it the caller of
# from_ssp_file must give one); other tools ignore it. Its namespace is declared on the root: libcosim's
# parser takes any attribute of osp:Algorithm for an algorithm.
OSP_ANNOTATION = "com.opensimulationplatform"
OSP_NAMESPACE = "https://opensimulationplatform.com/SSP/1.0"


def _parameters_of(description) -> dict:
    return {v.name: v for v in description.modelVariables if v.causality == "parameter"}


def design_parameters(fmu_path: str | Path, parameters: Mapping) -> list[tuple[str, str, object]]:
    """(name, SSV type, value) for each parameter: a sequence expands to name[1..n] (`material` is the order),
    an enumeration may be given by item name ("mean") or code. Refuses a name the FMU does not have."""
    known = _parameters_of(read_model_description(str(fmu_path)))
    entries = []
    for name, value in parameters.items():
        if isinstance(value, Sequence) and not isinstance(value, str):
            entries += [(f"{name}[{index}]", element) for index, element in enumerate(value, start=1)]
        else:
            entries.append((name, value))
    result = []
    for name, value in entries:
        variable = known.get(name)
        if variable is None:
            scalars = sorted(n for n in known if "[" not in n)
            raise ValueError(f"parameter {name!r} is not a parameter of {Path(fmu_path).name}; its parameters are "
                             f"{scalars} and the arrays material[j], k[m], k_diag[m], c[m], alpha[m], alpha_diag[m]")
        if variable.type == "Enumeration":  # libcosim reads no ssv:Enumeration; FMI 2 sets it as an Integer
            items = {item.name: int(item.value) for item in variable.declaredType.items}
            if isinstance(value, str):
                if value not in items:
                    raise ValueError(f"parameter {name} = {value!r} is not allowed: allowed values are {sorted(items)}")
                value = items[value]
            result.append((name, "Integer", int(value)))
        elif variable.type == "Integer":
            result.append((name, "Integer", int(value)))
        else:
            result.append((name, "Real", float(value)))
    return result


def _ssv(parameters: list[tuple[str, str, object]]) -> str:
    lines = [f'      <ssv:Parameter name={quoteattr(name)}><ssv:{kind} value="{value!r}"/></ssv:Parameter>'
             for name, kind, value in parameters]
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<ssv:ParameterSet {NAMESPACES} version="1.0" name="best_design">
  <ssv:Parameters>
{chr(10).join(lines)}
  </ssv:Parameters>
</ssv:ParameterSet>
"""


def _ssd(description, fmu_member: str, stop_time: float, step_size: float) -> str:
    connectors = "\n".join(
        f'          <ssd:Connector name={quoteattr(v.name)} kind="output"><ssc:Real/></ssd:Connector>'
        for v in description.modelVariables if v.causality == "output" and v.type == "Real")
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription {NAMESPACES} xmlns:osp="{OSP_NAMESPACE}" version="1.0" name="best_design">
  <ssd:System name="best_design" description="The best material order found, as a parameter set of the lattice FMU">
    <ssd:Elements>
      <ssd:Component name="{COMPONENT}" type="application/x-fmu-sharedlibrary" source="{fmu_member}">
        <ssd:Connectors>
{connectors}
        </ssd:Connectors>
        <ssd:ParameterBindings>
          <ssd:ParameterBinding source="{SSV_NAME}"/>
        </ssd:ParameterBindings>
      </ssd:Component>
    </ssd:Elements>
  </ssd:System>
  <ssd:DefaultExperiment startTime="0" stopTime="{float(stop_time)!r}">
    <ssd:Annotations>
      <ssc:Annotation type="{OSP_ANNOTATION}">
        <osp:Algorithm>
          <osp:FixedStepAlgorithm baseStepSize="{float(step_size)!r}"/>
        </osp:Algorithm>
      </ssc:Annotation>
    </ssd:Annotations>
  </ssd:DefaultExperiment>
</ssd:SystemStructureDescription>
"""


def write_best_design_ssp(fmu_path: str | Path, parameters: Mapping, out_path: str | Path, *, stop_time: float,
                          step_size: float = 0.01) -> Path:
    """Writes `out_path` (.ssp): the FMU, `parameters` as an .ssv bound to it in the .ssd, the experiment."""
    fmu_path, out_path = Path(fmu_path), Path(out_path)
    if not stop_time > 0 or not step_size > 0:
        raise ValueError(f"stop_time and step_size must be > 0 (got {stop_time}, {step_size})")
    description = read_model_description(str(fmu_path))
    fmu_member = f"resources/{fmu_path.name}"
    entries = design_parameters(fmu_path, parameters)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    partial = out_path.with_suffix(".ssp.partial")
    with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr(SSD_NAME, _ssd(description, fmu_member, stop_time, step_size))
        archive.writestr(SSV_NAME, _ssv(entries))
        archive.write(fmu_path, fmu_member)
    partial.replace(out_path)
    return out_path


def read_design_parameters(ssp_path: str | Path) -> dict[str, float | int]:
    """The parameter values an .ssp binds to its FMU, read with fmpy.ssp; refuses (ValueError) a parameter set
    that names a variable the FMU lacks, or one that is not a parameter, rather than let a tool ignore it."""
    from fmpy.ssp.ssd import read_ssd

    ssp_path = Path(ssp_path)
    system = read_ssd(str(ssp_path)).system
    values = {}
    with zipfile.ZipFile(ssp_path) as archive:
        for component in system.elements:
            with archive.open(component.source) as fmu:
                known = _parameters_of(read_model_description(fmu))
            for binding in component.parameterBindings:
                for parameter_set in binding.parameterValues:
                    for parameter in parameter_set.parameters:
                        if parameter.name not in known:
                            raise ValueError(f"{ssp_path.name}: parameter set {parameter_set.name!r} names "
                                             f"{parameter.name!r}, which is not a parameter of {component.source}")
                        cast = float if parameter.type == "Real" else int
                        values[parameter.name] = cast(parameter.value)
    return values
