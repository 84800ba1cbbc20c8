"""FMI 2.0 (Model Exchange and Co-Simulation): modelDescription.xml from the one variable table.

The template is builder/templates/fmi2_model_description.xml; this module hands it the table's variables
flattened into FMI 2 scalars (an array `k` of size C becomes `k[1]` ... `k[C]`, consecutive value references)
with their 1-based ScalarVariable indices, which <ModelStructure> refers to. An enumeration parameter
(diagonal_rule, solver) is an Integer with an Enumeration alias that names its items (`_elements`).
"""

from __future__ import annotations

from builder.rendering import default_experiment, model_summary, render
from builder.sources import SourceTree
from fmu_src.variables import DERIVATIVE, INTEGER, LOG_CATEGORIES, REAL, STATE, UNITS, Interface, c_literal
from scenes import SIZE_ANNOTATION


def _number(variable, value) -> str:
    return str(int(value)) if variable.type == INTEGER else repr(float(value))


def range_attributes(variable) -> list[tuple[str, str]]:
    """min and max as both model descriptions write them (where the table gives them)."""
    bounds = (("min", variable.minimum), ("max", variable.maximum))
    return [(key, _number(variable, value)) for key, value in bounds if value is not None]


ENUMERATION_ALIAS_SUFFIX = "_item"


def enumeration_alias(name: str) -> str:
    """The name of the Enumeration alias that declares the items of the Integer parameter `name` in FMI 2."""
    return name + ENUMERATION_ALIAS_SUFFIX


def _elements(interface: Interface) -> list[tuple]:
    """(variable, offset in it, element name, start, is the Enumeration alias) of every ScalarVariable, in order.

    An enumeration parameter is an Integer, which every FMI 2 importer sets (libcosim sets no Enumeration), with
    an Enumeration alias right after it: the same value reference, causality local, variability fixed and
    initial calculated, so it is not settable, and the items' names in its declared type."""
    elements = []
    for variable in interface.exposed:
        for offset, (name, start) in enumerate(zip(variable.element_names(), variable.element_starts())):
            elements.append((variable, offset, name, start, False))
            if variable.enumeration:
                elements.append((variable, offset, enumeration_alias(name), None, True))
    return elements


def scalar_variables(interface: Interface) -> tuple[list[dict], list[tuple[int, str]], list[int], list[int]]:
    """The ScalarVariables in value-reference order, and the indices of the outputs (each with the indices of the
    inputs it depends on directly, space-separated), of the derivatives (in the order of the continuous states)
    and of the initial unknowns."""
    scalars, outputs, derivatives, initial_unknowns = [], [], [], []
    state_offsets = interface.state_offsets()
    elements = _elements(interface)
    first_index = {}  # ScalarVariable index (1-based) of each variable's first element
    for index, (variable, offset, _, _, alias) in enumerate(elements, start=1):
        if offset == 0 and not alias:
            first_index[variable.name] = index
    for index, (variable, offset, name, start, alias) in enumerate(elements, start=1):
        vr = interface.value_references[variable.name] + offset
        if alias:
            scalars.append(
                {
                    "name": name,
                    "value_reference": vr,
                    "attributes": [("causality", "local"), ("variability", "fixed"), ("initial", "calculated")],
                    "description": f"{variable.element_names()[offset]} as the enumeration "
                    f"{variable.enumeration}: the same value, with its items' names",
                    "type": "Enumeration",
                    "type_attributes": [("declaredType", variable.enumeration)],
                }
            )
            continue
        if variable.causality == "parameter":
            attributes = [("causality", "parameter"), ("variability", "fixed")]
        elif variable.causality == "input":
            attributes = [("causality", "input"), ("variability", "continuous")]
        else:
            variability = "continuous" if variable.type == REAL else "discrete"
            attributes = [("causality", variable.causality), ("variability", variability), ("initial", "calculated")]
            if variable.causality == "output" or variable.role in (STATE, DERIVATIVE):
                initial_unknowns.append(index)
        if variable.causality == "output":
            outputs.append(
                (
                    index,
                    " ".join(
                        str(first_index[name]) for name in sorted(variable.depends_on, key=first_index.__getitem__)
                    ),
                )
            )
        type_attributes = []
        if variable.causality in ("parameter", "input"):
            type_attributes.append(
                ("start", c_literal(variable, start) if variable.type == INTEGER else repr(float(start)))
            )
        if variable.unit:
            type_attributes.append(("unit", variable.unit))
        type_attributes += range_attributes(variable)
        if variable.role == DERIVATIVE:
            type_attributes.append(("derivative", str(first_index[variable.derivative_of] + offset)))
            derivatives.append((state_offsets[variable.derivative_of] + offset, index))
        scalars.append(
            {
                "name": name,
                "value_reference": vr,
                "attributes": attributes,
                "description": variable.description,
                "type": variable.type,
                "type_attributes": type_attributes,
            }
        )
    return scalars, outputs, [i for _, i in sorted(derivatives)], sorted(initial_unknowns)


def enumeration_types(interface: Interface) -> list[dict]:
    """The enumeration types the exposed variables declare: name and items (name, value, description)."""
    return [
        {"name": v.enumeration, "items": [(name, value, text) for value, (name, text) in enumerate(v.items)]}
        for v in interface.exposed
        if v.enumeration
    ]


def lattice_size(interface) -> tuple[int, int, int] | None:
    """The lattice's rows, columns and depth, which its model descriptions declare in an annotation (read back by
    orchestrator.simulation.declared_lattice_size); None for a component of the armour system, which has no size."""
    if not isinstance(interface, Interface):
        return None
    return interface.rows, interface.cols, interface.depth


def co_simulation_capabilities(interface: Interface) -> list[tuple[str, str]]:
    """The <CoSimulation> attributes of a model with inputs: it extrapolates them linearly over a step
    (fmi2SetRealInputDerivatives) and gives its outputs' first derivatives (fmi2GetRealOutputDerivatives)."""
    if not any(variable.causality == "input" for variable in interface.exposed):
        return []
    return [("canInterpolateInputs", "true"), ("maxOutputDerivativeOrder", "1")]


def generate_model_description(
    interface: Interface, identifier: str, guid: str, scene, sources: list[str] | None = None
) -> str:
    """modelDescription.xml (FMI 2.0, Model Exchange and Co-Simulation) from the same table as the C header;
    `sources` are the C files in the FMU's sources/ (<SourceFiles>; default: the lattice's)."""
    scalars, outputs, derivatives, initial_unknowns = scalar_variables(interface)
    sources = sources if sources is not None else SourceTree(fmi_version=2).source_names()
    return render(
        "fmi2_model_description.xml",
        identifier=identifier,
        guid=guid,
        description=model_summary(interface, scene),
        event_indicators=interface.event_indicator_count(),
        sources=sources,
        units=UNITS,
        enumerations=enumeration_types(interface),
        log_categories=LOG_CATEGORIES,
        experiment=default_experiment(scene),
        variables=scalars,
        outputs=outputs,
        derivatives=derivatives,
        initial_unknowns=initial_unknowns,
        co_simulation_capabilities=co_simulation_capabilities(interface),
        annotation_tool=SIZE_ANNOTATION,
        lattice_size=lattice_size(interface),
    )
