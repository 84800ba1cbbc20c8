"""The FMU a run uses is checked, built and instantiated once before anything is searched: a broken or foreign
binary is refused with the FMU's own reason, or rebuilt when it is the scene's default FMU."""
from __future__ import annotations

import shutil
import zipfile

import pytest

from fmu_src import build
from orchestrator.fmu import FMUError, prepare_fmu
from scenes import Scene


def with_binary_of(target, source, path):
    """A copy of ``target`` whose binary is ``source``'s (under the target's name): a foreign build."""
    with zipfile.ZipFile(target) as a, zipfile.ZipFile(source) as b, zipfile.ZipFile(path, "w") as out:
        foreign = next(n for n in b.namelist() if n.startswith("binaries/") and n.endswith(".so"))
        for item in a.infolist():
            data = a.read(item)
            if item.filename.startswith("binaries/") and item.filename.endswith(".so"):
                data = b.read(foreign)
            out.writestr(item, data)
    return path


@pytest.fixture(scope="module")
def foreign(fmu_path, tmp_path_factory):
    """The armour FMU carrying the binary of the same scene built for 10 columns (another GUID)."""
    folder = tmp_path_factory.mktemp("foreign")
    other = build.build_fmu("armour_11x11", folder / "Other.fmu", cols=10)
    return with_binary_of(fmu_path, other, folder / "MassSpringLattice.fmu")


def test_a_given_fmu_with_a_foreign_binary_is_refused_with_the_fmus_reason(foreign):
    with pytest.raises(FMUError) as caught:
        prepare_fmu(Scene.load("armour_11x11"), str(foreign))
    message = str(caught.value)
    assert "cannot be instantiated" in message and "\n" not in message
    assert "GUID" in message or "guid" in message.lower()


def test_the_scenes_default_fmu_with_a_foreign_binary_is_rebuilt(foreign, tmp_path, monkeypatch, capfd):
    monkeypatch.setattr(build, "MODELS_DIR", tmp_path)
    shutil.copy(foreign, tmp_path / "MassSpringLattice.fmu")
    prepared = prepare_fmu(Scene.load("armour_11x11"))
    assert "its binary cannot be instantiated here" in capfd.readouterr().err
    assert prepared.path == tmp_path / "MassSpringLattice.fmu" and prepared.columns == 11
    prepare_fmu(Scene.load("armour_11x11"))  # now it is the scene's own build: used as it is
    assert "rebuilding" not in capfd.readouterr().err
