"""Shared fixtures: the FMU and the C core are built once per test session, into a temporary folder."""
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import build_fmu  # noqa: E402

PUBLISHED_SEQUENTIAL = (1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11)
PUBLISHED_BEST = (1, 7, 5, 9, 3, 6, 11, 8, 2, 4, 10)
PUBLISHED_PEAKS = {PUBLISHED_SEQUENTIAL: 1747.779979851872, PUBLISHED_BEST: 1497.8867334973704}


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: takes more than ~20 s (run with -m slow)")
    config.addinivalue_line("markers", "importers: FMI4j and fmi-sim, opt-in (run with -m importers; needs "
                                       "java + mvn, cargo + libclang-dev; the first run builds them for minutes)")


def pytest_collection_modifyitems(config, items):
    """The importers group runs only when asked for by name (-m importers), even before pyproject excludes it."""
    if "importers" in (config.getoption("markexpr") or ""):
        return
    skip = pytest.mark.skip(reason="opt-in group: run with `python -m pytest -m importers`")
    for item in items:
        if "importers" in item.keywords:
            item.add_marker(skip)


@pytest.fixture(scope="session")
def fmu_path(tmp_path_factory):
    """The 11 x 11 armour FMU, built with -Werror so any compiler warning fails the tests."""
    return build_fmu.build_fmu(output=tmp_path_factory.mktemp("fmu") / "MassSpringLattice.fmu", werror=True)


@pytest.fixture(scope="session")
def fmu3_path(tmp_path_factory):
    """The same armour FMU as FMI 3.0 co-simulation (fmu_src/fmi3/), built with -Werror."""
    return build_fmu.build_fmu(output=tmp_path_factory.mktemp("fmu3") / "MassSpringLattice-fmi3.fmu", werror=True,
                               fmi_version=3)


@pytest.fixture(scope="session")
def core_library(tmp_path_factory):
    return build_fmu.build_core_library(tmp_path_factory.mktemp("core"), werror=True)


@pytest.fixture()
def lattice(fmu_path):
    from orchestrator.simulation import LatticeFMU

    with LatticeFMU(fmu_path) as fmu:
        yield fmu
