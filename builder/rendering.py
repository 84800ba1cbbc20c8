"""The one jinja2 environment every generated file is rendered with: the model descriptions, the FMU's
documentation and cross-check files (builder/templates/), the report, explore.html and the SSP files
(orchestrator/templates/), the study file, and the measurement and compatibility pages.

A template is named by its path under the templates/ folder of the package that carries it: the builder's are
always there, and a package above it adds its folder with ``add_templates`` (names do not repeat across
folders). Files for a browser or an XML reader (.html, .xml, .ssd, .ssv, and .html.j2) are autoescaped, text
and Markdown are not. An XML attribute is written `name={{ value | quoted }}`: the value quoted and escaped as
xml.sax.saxutils.quoteattr does (double quotes unless the value holds one); a Markdown table's cell is written
`{{ value | cell }}`.
"""

from __future__ import annotations

import functools
from xml.sax.saxutils import quoteattr

import jinja2
from markupsafe import Markup

ESCAPED = (".html", ".html.j2", ".xml", ".ssd", ".ssv")
_PACKAGES = ["builder"]  # whose templates/ folders the environment loads from, in this order


def quoted(value) -> Markup:
    """An XML attribute value with its quotes, escaped (&, <, >, the quote, newlines)."""
    return Markup(quoteattr(str(value)))


def cell(value) -> str:
    """A value as one Markdown table cell: its | escaped, on one line (None: empty)."""
    return str("" if value is None else value).replace("|", "\\|").replace("\n", " ")


def _escaped(name: str | None) -> bool:
    return name is not None and name.endswith(ESCAPED)


def _loader() -> jinja2.BaseLoader:
    return jinja2.ChoiceLoader([jinja2.PackageLoader(package, "templates") for package in _PACKAGES])


@functools.cache
def environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=_loader(),
        autoescape=_escaped,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
    )
    env.filters.update(quoted=quoted, cell=cell)
    return env


def add_templates(package: str) -> jinja2.Environment:
    """The environment, with the templates/ folder of ``package`` (an importable package) loadable by name."""
    env = environment()
    if package not in _PACKAGES:
        _PACKAGES.append(package)
        env.loader = _loader()
    return env


def render(template: str, **context) -> str:
    return environment().get_template(template).render(**context)


def model_summary(interface, scene) -> str:
    """The one-line description of a scene's FMU (modelDescription.xml and the documentation)."""
    return scene.description or f"{interface.rows} x {interface.cols} mass-spring lattice"


def default_experiment(scene) -> dict[str, str]:
    """<DefaultExperiment>'s attributes for a scene."""
    return {"startTime": "0", "stopTime": repr(scene.horizon), "stepSize": repr(scene.communication_step)}


__all__ = ["ESCAPED", "add_templates", "cell", "default_experiment", "environment", "model_summary", "quoted", "render"]
