"""MkDocs hooks: the tables that must not drift from the code are generated from it at every build.

- ``fmu-reference.md``: at the line ``<!-- the variables of the default FMU -->`` go the tables of every
  parameter, output and local variable of the default scene's FMU, with unit, range, default and description,
  read from ``fmu_src/variables.py`` through the scene (``scenes.Scene.interface``), exactly as the build reads
  them to write the model description.
- ``optimisers.md``: at the line ``<!-- the options of every search -->`` goes each search's options with their
  defaults, read from the searches themselves (``orchestrator.search.SEARCHES``).
- ``fmu-reference.md``: at the line ``<!-- the variables of the component FMUs -->`` go the projectile's and the
  hull's parameters, inputs and outputs, read from their tables (``fmu_src.component_table``) as the build reads
  them, with the inputs each output depends on directly (its ``<ModelStructure>`` dependencies).
"""

from __future__ import annotations

VARIABLES = "<!-- the variables of the default FMU -->"
OPTIONS = "<!-- the options of every search -->"
COMPONENTS = "<!-- the variables of the component FMUs -->"


def on_page_markdown(markdown: str, page, config, files) -> str:
    generated = {
        "fmu-reference.md": ((VARIABLES, variable_tables), (COMPONENTS, component_tables)),
        "optimisers.md": ((OPTIONS, search_options),),
    }
    if page.file.src_uri not in generated:
        return markdown
    for marker, make in generated[page.file.src_uri]:
        if marker not in markdown:
            raise ValueError(f"{page.file.src_uri}: the line {marker} is missing (the hook puts its table there)")
        markdown = markdown.replace(marker, make())
    return markdown


def search_options() -> str:
    from orchestrator.search import SEARCHES
    from orchestrator.search.polish import Polished

    lines = ["| search | options (defaults) | polishing share of the budget |", "|---|---|---|"]
    for name, search in SEARCHES.items():
        options = ", ".join(f"`{key}` {value!r}" for key, value in search.OPTIONS.items() if key != "budget")
        polish = "none" if search.POLISH is None else f"{search.POLISH:g}"
        lines.append(f"| `{name}` | {cell(options) or 'none'} | {polish} |")
    shared = ", ".join(
        f"`{key}` {value!r}" for key, value in Polished.OPTIONS.items() if key not in ("budget", "polish")
    )
    lines += ["", f"Every search takes `budget`; a polished one also `polish` (its share above) and {shared}."]
    return "\n".join(lines) + "\n"


def variable_tables(scene_name: str = "armour_11x11") -> str:
    from scenes import Scene

    scene = Scene.load(scene_name)
    interface = scene.interface()
    headings = {
        "parameter": "Parameters",
        "output": "Outputs",
        "local": "Continuous states, derivatives and event indicators (local variables)",
    }
    lines = [
        f"The default FMU is the scene `{scene.name}`: a lattice of {interface.rows} rows by {interface.cols} "
        "columns. Arrays are written with their first and last element; in FMI 2 each element is a scalar "
        "variable of its own. A range in brackets includes its end, in parentheses excludes it.",
        "",
    ]
    lines += code_table(interface)
    for causality, heading in headings.items():
        lines += [
            f"## {heading}",
            "",
            "| name | type | unit | range | default | description |",
            "|---|---|---|---|---|---|",
        ]
        lines += [row(v) for v in interface.exposed if v.causality == causality]
        lines.append("")
    if interface.fixed:
        lines += [
            "## Compiled in by this scene",
            "",
            "These parameters of the model are constants of the default FMU (another scene may expose them): "
            + ", ".join(f"`{v.name}` = {start_text(v.start)}" for v in interface.fixed)
            + ".",
            "",
        ]
    return "\n".join(lines)


COMPONENT_HEADINGS = {"parameter": "parameters", "input": "inputs", "output": "outputs"}


def component_tables() -> str:
    """Each component FMU's parameters, inputs and outputs (its derivatives, local variables, left out: they are
    the states' rates), an output with the inputs it depends on directly."""
    from fmu_src.component_table import COMPONENT_MODELS, component_table

    lines = []
    for model in COMPONENT_MODELS:
        table = component_table(model)
        lines += [
            f"### {table.identifier} (`python build_fmu.py --model {model}`)",
            "",
            f"{table.description}. "
            f"Default experiment: {table.horizon:g} s, communication step {table.communication_step:g} s.",
            "",
        ]
        for causality, heading in COMPONENT_HEADINGS.items():
            variables = [v for v in table.variables if v.causality == causality]
            if not variables:
                continue
            outputs = causality == "output"
            lines += [
                f"**{table.identifier}'s {heading}**",
                "",
                "| name | type | unit | range | default | " + ("depends on | " if outputs else "") + "description |",
                "|---|---|---|---|---|" + ("---|" if outputs else "") + "---|",
            ]
            lines += [row(v, dependencies=outputs) for v in variables]
            lines.append("")
    return "\n".join(lines)


def code_table(interface) -> list[str]:
    """Every parameter set by a code: each Enumeration's items (FMPy sets an FMI 3 Enumeration only by its code,
    and FMI 2 declares them Integers), and the Integer switches whose few values have meanings."""
    lines = [
        "## Codes",
        "",
        (
            "Every parameter a tool sets by a code, with what each code means (an Enumeration "
            "takes its item's code in every importer: FMPy sets an FMI 3 Enumeration only by its "
            "code)."
        ),
        "",
        "| name | type | code: meaning | default |",
        "|---|---|---|---|",
    ]
    fixed = {variable.name for variable in interface.fixed}
    for variable in interface.exposed + interface.fixed:
        if variable.causality != "parameter" or variable.size is not None:
            continue
        if variable.enumeration:
            codes = "; ".join(f"`{code}` {name}: {meaning}" for code, (name, meaning) in enumerate(variable.items))
            kind = f"Enumeration `{variable.enumeration}`"
        elif (
            variable.allowed
            and variable.type != "Real"
            and variable.maximum is not None
            and variable.minimum is not None
            and variable.maximum - variable.minimum <= 5
        ):
            codes, kind = variable.allowed, variable.type
        else:
            continue
        default = start_text(variable.start) + (" (compiled in by this scene)" if variable.name in fixed else "")
        lines.append(f"| `{variable.name}` | {cell(kind)} | {cell(codes)} | {default} |")
    return lines + [""]


def row(variable, dependencies: bool = False) -> str:
    """A variable's table row; with ``dependencies``, a column of the inputs an output depends on directly."""
    texts = [
        name_text(variable),
        type_text(variable),
        f"`{variable.unit}`" if variable.unit else "",
        range_text(variable),
        start_text(variable.start) if variable.causality in ("parameter", "input") else "",
    ]
    if dependencies:
        texts.append(dependency_text(variable))
    return "| " + " | ".join(cell(text) for text in (*texts, variable.description)) + " |"


def dependency_text(variable) -> str:
    return ", ".join(f"`{name}`" for name in variable.depends_on) or "none"


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
