"""Shared fixtures: the FMU and the C core are built once per test session, into a temporary folder.

Each session keeps its temporary files in a folder of its own, removed when the session ends: pytest's
--basetemp (unless given) and the TMPDIR of the session and of every program it starts (Dask's scratch space,
Chromium's profiles), so nothing is left in the TMPDIR the suite was started with. pytest's default, with this
project's retention policy "none", is one numbered folder per session under a folder every session of the same
user shares, and a session that ends removes every numbered folder it finds there, a running session's included:
two test runs side by side would delete each other's FMUs.

The session compiles each distinct set of C sources once (builder.build's LATTICE_BUILD_CACHE, a temporary
folder removed when the session ends, inherited by the command lines the tests start): the many FMUs the tests
build alike differ only in their paths, and every build still generates, zips and checks its own FMU.
"""

import os
import shutil
import tempfile
from pathlib import Path

import pytest

from compatibility import add_option, check_recording
from builder import build as build_fmu

ROOT = Path(__file__).resolve().parents[1]


def pytest_addoption(parser):
    add_option(parser)  # --record-compatibility: the importer tests write their compatibility rows


@pytest.hookimpl(tryfirst=True)  # before pytest's own tmpdir plugin reads --basetemp
def pytest_configure(config):
    check_recording(config)
    session = tempfile.mkdtemp(prefix="lattice-pytest-")
    config.add_cleanup(lambda: shutil.rmtree(session, ignore_errors=True))
    if config.option.basetemp is None:
        config.option.basetemp = os.path.join(session, "pytest")
    own_tmp = os.path.join(session, "tmp")
    os.mkdir(own_tmp)
    previous = os.environ.get("TMPDIR"), tempfile.tempdir
    os.environ["TMPDIR"], tempfile.tempdir = own_tmp, own_tmp
    config.add_cleanup(lambda: _restore_tmpdir(*previous))
    if build_fmu.BUILD_CACHE_VARIABLE not in os.environ:
        folder = tempfile.mkdtemp(prefix="lattice_build_cache_")
        os.environ[build_fmu.BUILD_CACHE_VARIABLE] = folder
        config.add_cleanup(
            lambda: (shutil.rmtree(folder, ignore_errors=True), os.environ.pop(build_fmu.BUILD_CACHE_VARIABLE, None))
        )


def _restore_tmpdir(variable, module) -> None:
    if variable is None:
        os.environ.pop("TMPDIR", None)
    else:
        os.environ["TMPDIR"] = variable
    tempfile.tempdir = module


def pytest_collection_modifyitems(config, items):
    """The importers group runs only when asked for by name (-m importers), even before pyproject excludes it. The
    marker is looked up as a marker: an item's keywords also hold its folders' names (a checkout in a folder named
    importers)."""
    if "importers" in (config.getoption("markexpr") or ""):
        return
    skip = pytest.mark.skip(reason="opt-in group: run with `python -m pytest -m importers`")
    for item in items:
        if item.get_closest_marker("importers") is not None:
            item.add_marker(skip)


@pytest.fixture(scope="session")
def fmu_path(tmp_path_factory):
    """The 11 x 11 armour FMU, built with -Werror so any compiler warning fails the tests."""
    return build_fmu.build_fmu(output=tmp_path_factory.mktemp("fmu") / "MassSpringLattice.fmu", werror=True)


@pytest.fixture(scope="session")
def fmu3_path(tmp_path_factory):
    """The same armour FMU as FMI 3.0 co-simulation (fmu_src/fmi3/), built with -Werror."""
    return build_fmu.build_fmu(
        output=tmp_path_factory.mktemp("fmu3") / "MassSpringLattice-fmi3.fmu", werror=True, fmi_version=3
    )


@pytest.fixture(scope="session")
def core_library(tmp_path_factory):
    return build_fmu.build_core_library(tmp_path_factory.mktemp("core"), werror=True)


@pytest.fixture()
def lattice(fmu_path):
    from orchestrator.simulation import LatticeFMU

    with LatticeFMU(fmu_path) as fmu:
        yield fmu


@pytest.fixture(scope="session")
def armour_fmu_of_width(tmp_path_factory):
    """The armour scene over C columns (C! orders of the study's first C materials), built once per width."""
    built = {}

    def fmu(columns):
        if columns not in built:
            built[columns] = build_fmu.build_fmu(
                "armour_11x11", tmp_path_factory.mktemp(f"fmu{columns}") / "lattice.fmu", cols=columns, werror=True
            )
        return built[columns]

    return fmu
