"""The documentation site builds with warnings as errors, and its FMU reference names every variable of the FMU.

The build catches a broken link, a missing page or a nav entry without its file (mkdocs build --strict); the
reference page is generated from fmu_src/variables.py at build time (docs/hooks.py), and this checks it
against the model description of an FMU actually built, so neither can drift from the other.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
from fmpy import read_model_description

pytest.importorskip("mkdocs", reason='the docs extra is not installed (pip install -e ".[docs]")')

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def site():
    """The site built into a temporary folder (removed afterwards): {page path: html}."""
    with tempfile.TemporaryDirectory(prefix="lattice_docs_") as folder:
        done = subprocess.run(
            [
                sys.executable,
                "-m",
                "mkdocs",
                "build",
                "--strict",
                "--config-file",
                str(ROOT / "mkdocs.yml"),
                "--site-dir",
                folder,
            ],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=600,
            env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
        )
        assert done.returncode == 0, done.stderr[-4000:]
        yield {str(p.relative_to(folder)): p.read_text(encoding="utf-8") for p in Path(folder).rglob("*.html")}


def test_the_site_builds_strict_with_every_page(site):
    for page in (
        "index.html",
        "tutorial/index.html",
        "model/index.html",
        "fmu-reference/index.html",
        "optimisers/index.html",
        "exhaustive/index.html",
        "reliability/index.html",
        "other-tools/index.html",
        "design/index.html",
        "measurements/index.html",
        "changelog/index.html",
    ):
        assert page in site, sorted(site)


def test_the_fmu_reference_names_every_parameter_and_output_of_the_built_fmu(site, fmu_path):
    html = site["fmu-reference/index.html"]
    named = set(re.findall(r"<code>([^<]+)</code>", html))
    arrays: dict[str, int] = {}
    missing = []
    for variable in read_model_description(str(fmu_path)).modelVariables:
        if variable.causality not in ("parameter", "output"):
            continue
        match = re.fullmatch(r"(\w+)\[(\d+)\]", variable.name)
        if match:
            arrays[match.group(1)] = max(arrays.get(match.group(1), 0), int(match.group(2)))
        elif variable.name not in named:
            missing.append(variable.name)
    for base, last in arrays.items():  # an array is named by its first and last element
        if f"{base}[1]" not in named or f"{base}[{last}]" not in named:
            missing.append(f"{base}[1..{last}]")
    assert not missing, f"the FMU reference does not name {missing}"
    assert arrays, "the built FMU has no array parameter (material[j]): the test reads the wrong FMU"


def test_the_fmu_reference_gives_every_enumerations_codes_read_from_the_built_fmu(site, fmu3_path):
    """Each Enumeration parameter of the built FMI 3 FMU is listed with every item's code and name, so a user of an
    importer that sets only codes (FMPy, for an FMI 3 Enumeration) can set it."""
    from html import unescape

    html = unescape(site["fmu-reference/index.html"])
    codes = html[html.index('id="codes"') : html.index('id="parameters"')]
    description = read_model_description(str(fmu3_path))
    enumerations = {t.name: t for t in description.typeDefinitions if t.type == "Enumeration"}
    listed = 0
    for variable in description.modelVariables:
        declared = variable.declaredType
        if variable.causality != "parameter" or declared is None or declared.name not in enumerations:
            continue
        row = next(row for row in codes.split("<tr>") if f"<td><code>{variable.name}</code></td>" in row)
        for item in enumerations[declared.name].items:
            assert f"<code>{item.value}</code> {item.name}:" in row, (variable.name, item.name)
        listed += 1
    assert listed >= 2  # diagonal_rule and solver at least


def test_the_fmu_reference_lists_every_variable_of_each_component_fmu_with_its_unit_and_default(site):
    """The projectile's and the hull's parameters, inputs and outputs, each in its component's section with its
    unit, its default (parameters and inputs) and the inputs it depends on (outputs), as their tables give them."""
    from html import unescape

    from fmu_src.component_table import COMPONENT_MODELS, component_table

    html = unescape(site["fmu-reference/index.html"])
    sections = html.split("<h3 id=")[1:]  # the part before the first is the navigation
    for model in COMPONENT_MODELS:
        table = component_table(model)
        (section,) = [s for s in sections if f"--model {model}</code>" in s.split("</h3>")[0]]
        rows = {
            re.search(r"<td><code>([^<]+)</code></td>", row).group(1): row
            for row in section.split("<tr>")
            if row.startswith("\n<td><code>") or row.startswith("<td><code>")
        }
        listed = [v for v in table.variables if v.causality in ("parameter", "input", "output")]
        assert sorted(rows) == sorted(v.name for v in listed), model
        for variable in listed:
            cells = re.findall(r"<td>(.*?)</td>", rows[variable.name], flags=re.S)
            assert cells[2] == (f"<code>{variable.unit}</code>" if variable.unit else ""), variable.name
            if variable.causality != "output":
                assert float(cells[4]) == pytest.approx(variable.start), variable.name
            else:
                named = re.findall(r"<code>([^<]+)</code>", cells[5])
                assert named == list(variable.depends_on) or (not variable.depends_on and cells[5] == "none")
