"""MkDocs hooks: the FMU reference page is generated from the one table of variables at every build.

``fmu-reference.md`` holds the prose; at the line ``<!-- the variables of the default FMU -->`` this hook
puts the tables of every parameter, output and local variable of the default scene's FMU, with unit, range,
default and description, read from ``fmu_src/variables.py`` through the scene (``scenes.Scene.interface``),
exactly as the build reads them to write the model description. So the page cannot drift from the FMU.
"""
from __future__ import annotations

MARKER = "<!-- the variables of the default FMU -->"
PAGE = "fmu-reference.md"


def on_page_markdown(markdown: str, page, config, files) -> str:
    if page.file.src_uri != PAGE:
        return markdown
    if MARKER not in markdown:
        raise ValueError(f"{PAGE}: the line {MARKER} is missing (the hook puts the variable tables there)")
    return markdown.replace(MARKER, variable_tables())


def variable_tables(scene_name: str = "armour_11x11") -> str:
    from scenes import Scene

    scene = Scene.load(scene_name)
    interface = scene.interface()
    headings = {"parameter": "Parameters", "output": "Outputs",
                "local": "Continuous states, derivatives and event indicators (local variables)"}
    lines = [f"The default FMU is the scene `{scene.name}`: a lattice of {interface.rows} rows by {interface.cols} "
             "columns. Arrays are written with their first and last element; in FMI 2 each element is a scalar "
             "variable of its own. A range in brackets includes its end, in parentheses excludes it.", ""]
    for causality, heading in headings.items():
        lines += [f"## {heading}", "", "| name | type | unit | range | default | description |",
                  "|---|---|---|---|---|---|"]
        lines += [row(v) for v in interface.exposed if v.causality == causality]
        lines.append("")
    if interface.fixed:
        lines += ["## Compiled in by this scene", "",
                  "These parameters of the model are constants of the default FMU (another scene may expose them): "
                  + ", ".join(f"`{v.name}` = {start_text(v.start)}" for v in interface.fixed) + ".", ""]
    return "\n".join(lines)


def row(variable) -> str:
    return "| " + " | ".join(cell(text) for text in (
        name_text(variable), type_text(variable), f"`{variable.unit}`" if variable.unit else "",
        range_text(variable), start_text(variable.start) if variable.causality == "parameter" else "",
        variable.description)) + " |"


def name_text(variable) -> str:
    names = variable.element_names()
    if len(names) == 1:
        return f"`{names[0]}`"
    return f"`{names[0]}` ... `{names[-1]}`"


def type_text(variable) -> str:
    if variable.enumeration:
        return f"Enumeration `{variable.enumeration}`"
    return variable.type


def range_text(variable) -> str:
    if variable.causality != "parameter":
        return ""
    if variable.enumeration:
        return ", ".join(f"`{name}` ({code})" for code, (name, _) in enumerate(variable.items))
    return variable.allowed_text()


def start_text(start) -> str:
    if start is None:
        return ""
    if isinstance(start, tuple):
        if all(s == start[0] for s in start):
            return f"{start[0]:g} each"
        return ", ".join(f"{s:g}" for s in start)
    return f"{start:g}"


def cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")
