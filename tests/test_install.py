"""`pip install .` (not editable) gives working console scripts that need nothing from the source tree.

The project is copied to a temporary folder, installed from there into a fresh virtual environment, and the
copy is deleted before anything runs: whatever the scripts need (the FMU's C sources, the scene files) must
have been installed. The copy's models/ holds the session's FMU, as build_fmu.py leaves it before a wheel is
built: the installation carries it (setup.py), and runs the default scene from it where no compiler is found.
The fresh environment sees this environment's site-packages for the dependencies only (a path in a .pth file:
the editable install of this checkout that lives there is not activated); pip fetches only the build backend
(setuptools), as for any `pip install .`.
"""

import os
import shutil
import subprocess
import sys
import sysconfig
import venv
import zipfile
from pathlib import Path

import pytest

from conftest import ROOT

SOURCE_IGNORE = shutil.ignore_patterns(
    ".git", "models", "results", "build", "*.egg-info", "__pycache__", "bench", ".pytest_cache", "*.fmu"
)


@pytest.fixture(scope="module")
def installed(tmp_path_factory, fmu_path):
    """The bin folder of a fresh virtual environment with the project installed from a deleted copy."""
    folder = tmp_path_factory.mktemp("install")
    source, environment = folder / "source", folder / "venv"
    shutil.copytree(ROOT, source, ignore=SOURCE_IGNORE)
    (source / "models").mkdir()
    shutil.copy(fmu_path, source / "models" / "MassSpringLattice.fmu")
    venv.EnvBuilder(with_pip=False).create(environment)
    python = environment / "bin" / "python"
    site_packages = subprocess.run(
        [python, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    (Path(site_packages) / "dependencies.pth").write_text(sysconfig.get_path("purelib") + "\n")
    result = subprocess.run(
        [sys.executable, "-m", "pip", "--python", str(python), "install", "--quiet", "--no-deps", str(source)],
        capture_output=True,
        text=True,
        cwd=folder,
    )
    assert result.returncode == 0, result.stderr
    shutil.rmtree(source)
    return environment / "bin"


def run(command, cwd, timeout=300, environment=None):
    environment = {
        **{k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")},
        **(environment or {}),
    }
    return subprocess.run(command, capture_output=True, text=True, cwd=cwd, env=environment, timeout=timeout)


def test_console_scripts_answer_help_from_anywhere(installed, tmp_path):
    for script in ("lattice-build", "lattice-search"):
        result = run([installed / script, "--help"], tmp_path)
        assert result.returncode == 0, result.stderr
        assert result.stdout.startswith(f"usage: {script}")


def test_the_installed_modules_are_the_installed_copies(installed, tmp_path):
    modules = "build_fmu, orchestrator, scenes, fmu_src, builder, reference"
    result = run(
        [installed / "python", "-c", f"import {modules}; print('\\n'.join(m.__file__ for m in ({modules})))"], tmp_path
    )
    assert result.returncode == 0, result.stderr
    for path in result.stdout.split():
        assert Path(path).is_relative_to(installed.parent), path


@pytest.mark.slow
def test_installed_lattice_build_writes_the_fmu_to_models_under_the_current_folder(installed, tmp_path):
    """Compiles the FMU from the installed sources (about 10 s), then a tiny search runs on it."""
    result = run([installed / "lattice-build", "--scene", "two_masses_linear"], tmp_path)
    assert result.returncode == 0, result.stderr
    fmu = tmp_path / "models" / "TwoMassesLinear.fmu"
    assert result.stdout.strip() == str(Path("models") / "TwoMassesLinear.fmu") and fmu.is_file()
    with zipfile.ZipFile(fmu) as archive:
        assert "sources/model.c" in archive.namelist()
    result = run(
        [
            installed / "lattice-search",
            "--method",
            "sequential",
            "--budget",
            "1",
            "--repeats",
            "1",
            "--executor",
            "serial",
            "--no-progress",
            "--no-local-check",
            "--out",
            "report",
        ],
        tmp_path,
    )
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "models" / "MassSpringLattice.fmu").is_file()  # the default scene's FMU, built on demand
    assert (tmp_path / "report" / "results.json").is_file()


def test_a_bad_scene_is_one_line(installed, tmp_path):
    result = run([installed / "lattice-build", "--scene", "../../etc/passwd"], tmp_path)
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and "scene" in result.stderr and "Traceback" not in result.stderr


def test_without_a_compiler_the_installed_package_runs_the_default_scene_and_refuses_another(
    installed, tmp_path, fmu_path
):
    """CC names no compiler: the default scene runs from the FMU the installation carries; another lattice
    is refused in one line naming the compiler to install."""
    no_compiler = {"CC": str(tmp_path / "no-such-cc")}
    search = [
        installed / "lattice-search",
        "--method",
        "sequential",
        "--budget",
        "1",
        "--repeats",
        "1",
        "--executor",
        "serial",
        "--no-progress",
        "--no-local-check",
        "--no-sensitivity",
        "--diagonal-rule",
        "receiver",
    ]
    result = run([*search, "--out", "report"], tmp_path, environment=no_compiler)
    assert result.returncode == 0, result.stderr
    assert "no C compiler" in result.stderr and "using the prebuilt MassSpringLattice.fmu" in result.stderr
    assert (tmp_path / "models" / "MassSpringLattice.fmu").read_bytes() == fmu_path.read_bytes()
    assert (tmp_path / "report" / "results.json").is_file()
    result = run([*search, "--cols", "5", "--out", "report5"], tmp_path, environment=no_compiler)
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
    assert "no C compiler was found" in result.stderr and "apt-get install gcc" in result.stderr
