"""documentation/index.html inside the FMU: the model in a page, every variable, the study's published numbers.

Rendered from builder/templates/documentation.html without simulating anything: the variables come from the
one table (fmu_src/variables.py), the published numbers from fmu_src/published.py, so the page describes the
FMU it ships in and the build stays a build.
"""

from __future__ import annotations

from builder.fmi2_description import enumeration_alias
from fmu_src.materials import STUDY_MATERIAL_COUNT, study_materials
from fmu_src.published import PUBLISHED_CONDITIONS, PUBLISHED_HORIZON, PUBLISHED_PEAKS, REFERENCE_POINTS
from builder.rendering import model_summary, render
from fmu_src.variables import INDICATOR, Interface, Variable
from scenes import is_study_scene


def _format(value) -> str:
    if value is None:
        return ""
    if isinstance(value, tuple):
        return ", ".join(f"{v:g}" for v in value)
    return f"{value:g}"


def variable_row(variable: Variable, fmi_version: int) -> dict:
    """One row of the variables table."""
    kind = "local" if variable.role == INDICATOR or variable.name.startswith("der(") else variable.causality
    if variable.enumeration:
        allowed = ", ".join(f"{code} = {name}" for code, (name, _) in enumerate(variable.items))
        type_text = (
            f"Enumeration {variable.enumeration}"
            if fmi_version == 3
            else f"Integer (its items named by the Enumeration {variable.enumeration} alias "
            f"{enumeration_alias(variable.name)})"
        )
    else:
        allowed = variable.allowed_text() if variable.causality == "parameter" else ""
        type_text = variable.type
    size = "" if variable.size is None else "[" + ", ".join(str(n) for n in (variable.shape or (variable.size,))) + "]"
    return {
        "name": variable.name + size,
        "type": type_text,
        "causality": kind,
        "unit": variable.unit or "",
        "start": _format(variable.start),
        "allowed": allowed,
        "description": variable.description,
    }


def documentation_html(fmi_version: int, interface: Interface, identifier: str, scene, fmi3_arrays: bool = True) -> str:
    """The page for the FMU of `scene` (FMI 2 or 3; FMI 3 with its parameter arrays as arrays unless fmi3_arrays is
    False)."""
    published = []
    starts = {v.name: v.start for v in interface.exposed + interface.fixed}
    if is_study_scene(scene):  # the published numbers hold for the study's scene alone
        published = [(list(order), repr(peak)) for order, peak in PUBLISHED_PEAKS.items()]
    rule = next((v for v in interface.exposed if v.name == "diagonal_rule" and v.enumeration), None)
    rule_codes = {name: code for code, (name, _) in enumerate(rule.items)} if rule else {}
    return render(
        "documentation.html",
        identifier=identifier,
        summary=model_summary(interface, scene),
        rule_codes=rule_codes,
        material_columns=interface.cols if "material" in starts else 0,
        fmi_version=fmi_version,
        arrays=fmi_version == 3 and fmi3_arrays,
        rows=interface.rows,
        cols=interface.cols,
        depth=interface.depth,
        published=published,
        horizon=f"{PUBLISHED_HORIZON:g}",
        conditions=PUBLISHED_CONDITIONS,
        rtol=f"{starts['rtol']:g}",
        reference_points=REFERENCE_POINTS,
        variables=[variable_row(v, fmi_version) for v in interface.exposed],
        fixed=[v.name for v in interface.fixed],
        materials=(scene.material_table() or study_materials(min(interface.cols, STUDY_MATERIAL_COUNT))).materials,
    )
