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

pytest.importorskip("mkdocs", reason="the docs extra is not installed (pip install -e \".[docs]\")")

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def site():
    """The site built into a temporary folder (removed afterwards): {page path: html}."""
    with tempfile.TemporaryDirectory(prefix="lattice_docs_") as folder:
        done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file",
                               str(ROOT / "mkdocs.yml"), "--site-dir", folder], cwd=ROOT, capture_output=True,
                              text=True, timeout=600, env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
        assert done.returncode == 0, done.stderr[-4000:]
        yield {str(p.relative_to(folder)): p.read_text(encoding="utf-8") for p in Path(folder).rglob("*.html")}


def test_the_site_builds_strict_with_every_page(site):
    for page in ("index.html", "tutorial/index.html", "model/index.html", "fmu-reference/index.html",
                 "optimisers/index.html", "exhaustive/index.html", "reliability/index.html",
                 "other-tools/index.html", "design/index.html", "measurements/index.html", "changelog/index.html"):
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
