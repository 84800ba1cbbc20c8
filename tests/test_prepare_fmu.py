"""The FMU a run uses is checked, built and instantiated once before anything is searched: a broken or foreign
binary is refused with the FMU's own reason, or rebuilt when it is the scene's default FMU."""

from __future__ import annotations

import shutil
import zipfile

import pytest

from builder import build
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


# ------------------------------------------------------------------------------------------ without a compiler


@pytest.fixture()
def no_compiler(tmp_path, monkeypatch):
    """No C compiler (CC names none), models/ and the prebuilt folder empty under tmp_path."""
    from orchestrator import fmu as prepared_fmu

    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    monkeypatch.setattr(build, "MODELS_DIR", tmp_path / "models")
    monkeypatch.setattr(prepared_fmu, "PREBUILT_DIR", tmp_path / "prebuilt")
    (tmp_path / "prebuilt").mkdir()
    assert not prepared_fmu.compiler_found()
    return tmp_path / "prebuilt"


def test_without_a_compiler_the_default_scene_runs_from_the_prebuilt_fmu(no_compiler, fmu_path, tmp_path, capfd):
    shutil.copy(fmu_path, no_compiler / "MassSpringLattice.fmu")
    prepared = prepare_fmu(Scene.load("armour_11x11"))
    assert "using the prebuilt MassSpringLattice.fmu" in capfd.readouterr().err
    assert prepared.path == tmp_path / "models" / "MassSpringLattice.fmu" and prepared.columns == 11
    assert prepared.path.read_bytes() == fmu_path.read_bytes()


@pytest.mark.parametrize("change", ["lattice", "materials"])
def test_without_a_compiler_another_lattice_or_table_is_refused_naming_the_compiler(
    no_compiler, fmu_path, tmp_path, change
):
    shutil.copy(fmu_path, no_compiler / "MassSpringLattice.fmu")
    table = tmp_path / "materials.csv"
    table.write_text(
        "name,k,k_diag,c,alpha,alpha_diag\n" + "".join(f"m{i},{10 * i},{5 * i},{0.5 * i},10,10\n" for i in range(1, 12))
    )
    scene = (
        build.resolve_scene("armour_11x11", cols=5)
        if change == "lattice"
        else build.resolve_scene("armour_11x11", materials=table)
    )
    with pytest.raises(FMUError) as caught:
        prepare_fmu(scene)
    message = str(caught.value)
    assert "\n" not in message and "no C compiler was found" in message and "no prebuilt FMU matches it" in message
    assert "apt-get install gcc" in message  # this machine's platform (Linux)
    assert not (tmp_path / "models").exists() or not list((tmp_path / "models").iterdir())


def test_without_a_compiler_a_prebuilt_fmu_that_cannot_be_instantiated_is_refused(no_compiler, foreign):
    shutil.copy(foreign, no_compiler / "MassSpringLattice.fmu")  # the scene's GUID outside, another build's binary
    with pytest.raises(FMUError, match=r"cannot be instantiated on this machine .*, and no C compiler was found"):
        prepare_fmu(Scene.load("armour_11x11"))


@pytest.mark.parametrize(
    "system, hint",
    [("Windows", "MinGW-w64 gcc"), ("Darwin", "xcode-select --install"), ("Linux", "apt-get install gcc")],
)
def test_the_compiler_to_install_is_named_for_each_platform(monkeypatch, system, hint):
    from orchestrator import fmu as prepared_fmu

    monkeypatch.setattr(prepared_fmu.platform, "system", lambda: system)
    assert hint in prepared_fmu.compiler_hint()


def test_without_a_compiler_a_prebuilt_fmu_without_this_platforms_binary_is_refused(no_compiler, fmu_path):
    """What a wheel whose FMU holds other platforms' binaries does here: refused, naming the compiler."""
    with zipfile.ZipFile(fmu_path) as source, zipfile.ZipFile(no_compiler / "MassSpringLattice.fmu", "w") as out:
        for item in source.infolist():
            if not item.filename.startswith("binaries/"):
                out.writestr(item, source.read(item))
    with pytest.raises(FMUError) as caught:
        prepare_fmu(Scene.load("armour_11x11"))
    message = str(caught.value)
    assert "\n" not in message and "cannot be instantiated on this machine" in message
    assert "no C compiler was found" in message and "apt-get install gcc" in message
