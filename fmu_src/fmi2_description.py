"""FMI 2.0 (Model Exchange and Co-Simulation): modelDescription.xml from the one variable table.

The template is fmu_src/templates/fmi2_model_description.xml; this module hands it the table's variables
flattened into FMI 2 scalars (an array `k` of size C becomes `k[1]` ... `k[C]`, consecutive value references)
with their 1-based ScalarVariable indices, which <ModelStructure> refers to.
"""
from __future__ import annotations

from fmu_src import MODEL_HEADERS, MODEL_SOURCES
from fmu_src.rendering import default_experiment, model_summary, render
from fmu_src.variables import DERIVATIVE, INTEGER, LOG_CATEGORIES, REAL, STATE, UNITS, Interface, c_literal

C_SOURCES = ["fmi2/fmi2_glue.c"] + MODEL_SOURCES
C_HEADERS = ["include/fmi2Functions.h", "include/fmi2FunctionTypes.h", "include/fmi2TypesPlatform.h"] + MODEL_HEADERS


def _number(variable, value) -> str:
    return str(int(value)) if variable.type == INTEGER else repr(float(value))


def scalar_variables(interface: Interface) -> tuple[list[dict], list[int], list[int], list[int]]:
    """The ScalarVariables in value-reference order, and the indices of the outputs, of the derivatives (in
    the order of the continuous states) and of the initial unknowns."""
    scalars, outputs, derivatives, initial_unknowns = [], [], [], []
    state_offsets = interface.state_offsets()
    first_index, index = {}, 0  # ScalarVariable index (1-based) of each variable's first element
    for variable in interface.exposed:
        first_index[variable.name] = index + 1
        index += variable.count
    for variable in interface.exposed:
        vr = interface.value_references[variable.name]
        for offset, (name, start) in enumerate(zip(variable.element_names(), variable.element_starts())):
            index = first_index[variable.name] + offset
            if variable.causality == "parameter":
                attributes = [("causality", "parameter"), ("variability", "fixed")]
            else:
                variability = "continuous" if variable.type == REAL else "discrete"
                attributes = [("causality", variable.causality), ("variability", variability),
                              ("initial", "calculated")]
                if variable.causality == "output" or variable.role in (STATE, DERIVATIVE):
                    initial_unknowns.append(index)
            if variable.causality == "output":
                outputs.append(index)
            type_attributes = []
            if variable.enumeration:
                type_attributes.append(("declaredType", variable.enumeration))
            if variable.causality == "parameter":
                type_attributes.append(("start", c_literal(variable, start) if variable.type == INTEGER
                                        else repr(float(start))))
            if variable.unit:
                type_attributes.append(("unit", variable.unit))
            if variable.minimum is not None:
                type_attributes.append(("min", _number(variable, variable.minimum)))
            if variable.maximum is not None:
                type_attributes.append(("max", _number(variable, variable.maximum)))
            if variable.role == DERIVATIVE:
                type_attributes.append(("derivative", str(first_index[variable.derivative_of] + offset)))
                derivatives.append((state_offsets[variable.derivative_of] + offset, index))
            scalars.append({"name": name, "value_reference": vr + offset, "attributes": attributes,
                            "description": variable.description,
                            "type": "Enumeration" if variable.enumeration else variable.type,
                            "type_attributes": type_attributes})
    return scalars, outputs, [i for _, i in sorted(derivatives)], sorted(initial_unknowns)


def enumeration_types(interface: Interface) -> list[dict]:
    """The enumeration types the exposed variables declare: name and items (name, value, description)."""
    return [{"name": v.enumeration,
             "items": [(name, value, text) for value, (name, text) in enumerate(v.items)]}
            for v in interface.exposed if v.enumeration]


def generate_model_description(interface: Interface, identifier: str, guid: str, scene) -> str:
    """modelDescription.xml (FMI 2.0, Model Exchange and Co-Simulation) from the same table as the C header."""
    scalars, outputs, derivatives, initial_unknowns = scalar_variables(interface)
    return render("fmi2_model_description.xml", identifier=identifier, guid=guid,
                  description=model_summary(interface, scene), event_indicators=interface.event_indicator_count(),
                  sources=C_SOURCES, units=UNITS, enumerations=enumeration_types(interface),
                  log_categories=LOG_CATEGORIES, experiment=default_experiment(scene), variables=scalars,
                  outputs=outputs, derivatives=derivatives, initial_unknowns=initial_unknowns)
