"""The FMI Cross-Check folder (builder/cross_check.py) passes FMPy's validator of vendor repositories.

The fast tests write the armour's folders from the session's FMUs (FMI 2.0 and 3.0, cs and me); the slow one
runs `python build_fmu.py --cross-check DIR` as a user does: every scene built, imported and validated.
"""

from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.cross_check.validate_vendor_repo import validate_cross_check_result, validate_test_fmu

import build_fmu
from conftest import ROOT
from builder import cross_check
from builder.build import platform_folder
from builder.cross_check import CROSS_CHECK_SCENES, EXTRA, MAX_SIGNALS, write_cross_check

ARMOUR = CROSS_CHECK_SCENES[0]
# fmpy.cross_check imports scipy.ndimage.filters, which SciPy deprecates
pytestmark = pytest.mark.filterwarnings("ignore:Please import:DeprecationWarning")


def model_folders(out: Path, kind: str) -> list[Path]:
    """The FMU folders (kind "fmus") or the importer's result folders ("results") of a cross-check tree."""
    marker = {
        "fmus": lambda files: any(f.endswith(".fmu") for f in files),
        "results": lambda files: "passed" in files or "failed" in files,
    }[kind]
    return sorted(Path(root) for root, _, files in os.walk(out / kind) if marker(files))


def assert_valid(out: Path, expected: int) -> None:
    fmus, results = model_folders(out, "fmus"), model_folders(out, "results")
    assert len(fmus) == len(results) == expected
    for folder in fmus:
        assert validate_test_fmu(str(folder)) == [], folder
    for folder in results:
        assert validate_cross_check_result(str(folder)) == [], folder
        assert (folder / "passed").is_file(), (folder / "ReadMe.md").read_text()


@pytest.fixture(scope="module")
def armour_folder(fmu_path, fmu3_path, tmp_path_factory):
    out = tmp_path_factory.mktemp("cross_check")
    results = write_cross_check(
        out, (ARMOUR,), fmus={(ARMOUR.scene, "2.0"): fmu_path, (ARMOUR.scene, "3.0"): fmu3_path}
    )
    return out, results


def test_fmpys_validator_finds_no_problem(armour_folder):
    out, results = armour_folder
    assert sorted((r.fmi_version, r.fmi_type) for r in results) == [
        ("2.0", "cs"),
        ("2.0", "me"),
        ("3.0", "cs"),
        ("3.0", "me"),
    ]
    assert all(r.problem is None for r in results), [r.problem for r in results]
    assert_valid(out, 4)
    platform = platform_folder()[0]
    assert {f.relative_to(out).parts[:4] for f in model_folders(out, "fmus")} == {
        ("fmus", version, kind, platform) for version in ("2.0", "3.0") for kind in ("cs", "me")
    }


def test_each_fmu_carries_its_reference_and_manifest(armour_folder):
    from lxml import etree

    out, _ = armour_folder
    for folder in model_folders(out, "fmus"):
        model = folder.name
        reference = (folder / f"{model}_ref.csv").read_bytes()
        with zipfile.ZipFile(folder / f"{model}.fmu") as fmu:
            assert fmu.read(f"{EXTRA}/{model}_ref.csv") == reference
            manifest = etree.fromstring(fmu.read(f"{EXTRA}/fmi-ls-manifest.xml"))
        assert manifest.get("{http://fmi-standard.org/fmi-ls-manifest}fmi-ls-name") == "org.fmi-standard.fmi-ls-ref"
        (related,) = manifest.findall("Related")
        assert related.get("source") == f"{model}_ref.csv" and related.get("role") == "result"


def test_the_reference_has_at_most_ten_signals_named_as_in_the_model_description(armour_folder):
    out, _ = armour_folder
    for folder in model_folders(out, "fmus"):
        model = folder.name
        header = (folder / f"{model}_ref.csv").read_text().splitlines()[0].split(",")
        names = [name.strip('"') for name in header]
        assert all(field.startswith('"') and field.endswith('"') for field in header)
        description = read_model_description(str(folder / f"{model}.fmu"))
        outputs = {v.name for v in description.modelVariables if v.causality == "output"}
        assert names[0] == "time" and 1 <= len(names) - 1 <= MAX_SIGNALS and set(names[1:]) <= outputs
        readme = (folder / "ReadMe.md").read_text()
        for variable in description.modelVariables:
            if variable.causality in ("parameter", "output"):
                assert f"| {variable.name} | {variable.causality} |" in readme


def test_an_import_that_leaves_the_band_is_written_as_failed(fmu_path, tmp_path, monkeypatch):
    imported = cross_check.import_with_fmpy

    def doubled_force(*args):
        result, settings = imported(*args)
        result["backplate_force"] *= 2.0
        return result, settings

    monkeypatch.setattr(cross_check, "import_with_fmpy", doubled_force)
    (result,) = [
        r
        for r in write_cross_check(tmp_path, (ARMOUR,), ("2.0",), fmus={(ARMOUR.scene, "2.0"): fmu_path})
        if r.fmi_type == "cs"
    ]
    assert result.verdict == "failed" and "backplate_force" in result.problem
    (folder,) = [f for f in model_folders(tmp_path, "results") if "/cs/" in f.as_posix()]
    assert (folder / "failed").is_file() and not (folder / "passed").exists()
    assert "Why it failed" in (folder / "ReadMe.md").read_text()
    out = np.genfromtxt(folder / f"{folder.name}_out.csv", delimiter=",", names=True, deletechars="")
    assert out["backplate_force"].max() > 0


def test_cross_check_refuses_options_it_would_ignore(tmp_path, capsys):
    for extra in (["-o", str(tmp_path / "x.fmu")], ["--fmi-version", "3"], ["--scene", "free_5x5"]):
        with pytest.raises(SystemExit) as exit_code:
            build_fmu.main(["--cross-check", str(tmp_path / "xc"), *extra])
        assert exit_code.value.code == 2
        assert "--cross-check builds its own scenes and versions" in capsys.readouterr().err
    assert not (tmp_path / "xc").exists()


@pytest.mark.slow
def test_the_cross_check_command_writes_every_scene_and_version(tmp_path):
    """About 3 minutes on 2 shared cores: six FMU builds, twelve FMPy imports."""
    result = subprocess.run(
        [sys.executable, "build_fmu.py", "--cross-check", str(tmp_path / "xc"), "--werror"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=1800,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    expected = len(CROSS_CHECK_SCENES) * 4
    assert result.stdout.count("passed") == expected, result.stdout
    assert_valid(tmp_path / "xc", expected)
