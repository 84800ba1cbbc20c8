"""The jinja2 environment the FMU's generated files are rendered with (the templates in builder/templates/).

Autoescaped for HTML and XML. An XML attribute is written `name={{ value | quoted }}`: the value quoted and
escaped as xml.sax.saxutils.quoteattr does (double quotes unless the value holds one).
"""
from __future__ import annotations

import functools
from pathlib import Path
from xml.sax.saxutils import quoteattr

import jinja2
from markupsafe import Markup

TEMPLATE_DIR = Path(__file__).resolve().parent / "templates"


def quoted(value) -> Markup:
    """An XML attribute value with its quotes, escaped (&, <, >, the quote, newlines)."""
    return Markup(quoteattr(str(value)))


@functools.cache
def environment() -> jinja2.Environment:
    env = jinja2.Environment(loader=jinja2.FileSystemLoader(TEMPLATE_DIR),
                             autoescape=jinja2.select_autoescape(["html", "xml"]), undefined=jinja2.StrictUndefined,
                             trim_blocks=True, lstrip_blocks=True, keep_trailing_newline=True)
    env.filters["quoted"] = quoted
    return env


def render(template: str, **context) -> str:
    return environment().get_template(template).render(**context)


def model_summary(interface, scene) -> str:
    """The one-line description of a scene's FMU (modelDescription.xml and the documentation)."""
    return scene.description or f"{interface.rows} x {interface.cols} mass-spring lattice"


def default_experiment(scene) -> dict[str, str]:
    """<DefaultExperiment>'s attributes for a scene."""
    return {"startTime": "0", "stopTime": repr(scene.horizon), "stepSize": repr(scene.communication_step)}
