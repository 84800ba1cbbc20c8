"""The build library (builder.build): it renders, compiles and zips, never simulates; same sources, same GUID."""

from __future__ import annotations

import re
import zipfile
from dataclasses import replace
from xml.etree import ElementTree

import pytest
from fmpy import read_model_description

import build_fmu
from builder import build
from builder import fmi2_description as fmi2
from builder import fmi3_description as fmi3
from builder.documentation import documentation_html
from fmu_src.published import PUBLISHED_PEAKS, REFERENCE_POINTS
from scenes import Scene


def _read(path, name):
    with zipfile.ZipFile(path) as archive:
        return archive.read(name).decode()


def test_the_command_line_builds_through_the_library_and_simulates_nothing(tmp_path, capsys, monkeypatch):
    import fmpy
    import fmpy.fmi2
    import fmpy.fmi3

    def refuse(*args, **kwargs):
        raise AssertionError("the build simulated")

    monkeypatch.setattr(fmpy, "simulate_fmu", refuse)
    for module, name in ((fmpy.fmi2, "FMU2Slave"), (fmpy.fmi2, "FMU2Model"), (fmpy.fmi3, "FMU3Slave")):
        monkeypatch.setattr(module, name, refuse)
    output = tmp_path / "cli.fmu"
    assert build_fmu.main(["--scene", "two_masses_linear", "-o", str(output)]) == 0
    assert capsys.readouterr().out.strip() == str(output)
    assert "TwoMassesLinear" in _read(output, "documentation/index.html")
    assert build_fmu.main(["--scene", "no_such_scene"]) == 2
    assert "scene 'no_such_scene' not found" in capsys.readouterr().err


def test_the_same_sources_give_the_same_guid_and_description(fmu_path):
    scene = Scene.load("armour_11x11")
    interface = scene.interface()
    guid = read_model_description(str(fmu_path)).guid
    assert (
        guid
        == build.model_guid(interface, scene.model_identifier)
        == build.model_guid(scene.interface(), scene.model_identifier)
    )
    assert _read(fmu_path, "modelDescription.xml") == fmi2.generate_model_description(
        interface, scene.model_identifier, guid, scene
    )
    changed = replace(scene, parameters={**scene.parameters, "F_total": 50.0})  # another start value
    assert build.model_guid(changed.interface(), changed.model_identifier) != guid


@pytest.mark.parametrize("version", [2, 3])
def test_text_is_escaped_in_every_rendered_file(version):
    description = 'Two "masses" <b>&amp;</b> a spring\'s <script>'
    scene = replace(Scene.load("two_masses_linear"), description=description)
    interface = scene.interface()
    module = fmi2 if version == 2 else fmi3
    root = ElementTree.fromstring(module.generate_model_description(interface, "Escaped", "{token}", scene))
    assert root.get("description") == description
    page = documentation_html(version, interface, "Escaped", scene)
    assert "<script>" not in page and "&lt;script&gt;" in page


def test_the_documentation_shows_the_one_table_of_published_numbers(fmu_path):
    page = _read(fmu_path, "documentation/index.html")
    for order, peak in PUBLISHED_PEAKS.items():
        assert f"<code>{list(order)}</code></td><td>{peak!r}</td>" in page
    for point in REFERENCE_POINTS:
        assert f"<td>{point.label}</td><td>{point.peak:.2f}</td>" in page


def test_a_resized_build_leaves_the_callers_scene_alone(tmp_path):
    scene = Scene.load("armour_11x11")
    resized = build.resolve_scene(scene, rows=3, cols=4)
    assert (resized.rows, resized.cols, resized.model_identifier) == (3, 4, "MassSpringLattice3x4")
    assert (scene.rows, scene.cols, scene.model_identifier) == (11, 11, "MassSpringLattice")


@pytest.mark.parametrize(
    "scene_name, change, identifier",
    [
        ("plate_11x11x11", dict(cols=7), "MassSpringPlate11x7x11"),
        ("plate_11x11x11", dict(load_patch=0), "MassSpringPlate_patch0"),
        ("plate_11x11x11", dict(load_patch=3), "MassSpringPlate"),
        ("plate_11x11x11", dict(cols=11, depth=11), "MassSpringPlate"),
        ("armour_11x11", dict(depth=3, load_patch=3), "MassSpringLattice11x11x3_patch3"),
    ],
)
def test_a_changed_scene_builds_under_its_own_name_so_variants_never_share_a_file(scene_name, change, identifier):
    assert build.resolve_scene(scene_name, **change).model_identifier == identifier


@pytest.mark.parametrize("version", [2, 3])
def test_every_description_declares_the_one_tables_units_and_log_categories(fmu_path, fmu3_path, version):
    from fmu_src.variables import LOG_CATEGORIES, UNITS

    root = ElementTree.fromstring(_read(fmu_path if version == 2 else fmu3_path, "modelDescription.xml"))
    assert [unit.get("name") for unit in root.iter("Unit")] == list(UNITS)
    assert [(c.get("name"), c.get("description")) for c in root.iter("Category")] == list(LOG_CATEGORIES)


def test_the_build_cache_compiles_each_set_of_sources_once_and_a_changed_file_again(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv(build.BUILD_CACHE_VARIABLE, str(cache))
    sources = tmp_path / "src with spaces"  # as make escapes them in the compiler's list of headers
    sources.mkdir()
    (sources / "value.h").write_text("#define VALUE 1\n")
    (sources / "lib.c").write_text('#include "value.h"\nint value(void) { return VALUE; }\n')
    compiled = []
    run = build.subprocess.run

    def counted(command, *args, **kwargs):
        if "-c" in command:
            compiled.append(command)
        return run(command, *args, **kwargs)

    monkeypatch.setattr(build.subprocess, "run", counted)

    def library(name):
        output = tmp_path / name
        build.compile_shared_library([sources / "lib.c"], output, [sources], werror=True)
        return output.read_bytes()

    first, again = library("first.so"), library("again.so")
    assert first == again and len(compiled) == 1 and len(list(cache.iterdir())) == 1
    (sources / "value.h").write_text("#define VALUE 2\n")  # a header the compiler reads, not a source named
    assert library("changed.so") != first and len(compiled) == 2
    build.compile_shared_library([sources / "lib.c"], tmp_path / "plain.so", [sources], werror=False)
    assert len(compiled) == 3  # -Werror is part of what a library depends on


def test_a_build_that_warns_is_not_cached_so_its_warning_is_printed_every_time(tmp_path, monkeypatch, capfd):
    monkeypatch.setenv(build.BUILD_CACHE_VARIABLE, str(tmp_path / "cache"))
    (tmp_path / "lib.c").write_text("int value(int unused) { return 1; }\n")
    for name in ("a.so", "b.so"):
        build.compile_shared_library([tmp_path / "lib.c"], tmp_path / name, [], werror=False)
        assert "unused" in capfd.readouterr().err
    assert not (tmp_path / "cache").exists()


def test_the_c_enumerations_and_material_fields_are_the_tables(fmu_path):
    """The C constants of each enumeration parameter come from its items in the variable table, and the C struct
    of a column's material from the material table's fields (generated into the FMU's sources at build time); no
    C source of the model spells them itself."""
    from fmu_src.core import DIAGONAL_RULES, ColumnConstants
    from fmu_src.materials import FIELD_NAMES
    from fmu_src.variables import TABLE_PARAMETERS, enumeration_values, enumerations

    header = _read(fmu_path, f"sources/{build.TABLE_HEADER}")
    assert header == build.generate_table_header()
    for variable in enumerations():
        declared = re.search(rf"enum {variable.enumeration} {{(.*?)}};", header, re.S).group(1)
        constants = dict(re.findall(r"(\w+) = (\d+),", declared))
        assert constants == {
            f"{variable.c_name}_{label.upper()}": str(value)
            for label, value in enumeration_values(variable.name).items()
        }
        for path in build.DEFAULT_MODEL_DIR.glob("*.[ch]"):
            assert not re.search(rf"\b({'|'.join(constants)})\s*=", path.read_text()), path.name
    assert DIAGONAL_RULES == {"receiver": 0, "mean": 1} == enumeration_values("diagonal_rule")
    struct = re.search(r"typedef struct {(.*?)} ColumnConstants;", header, re.S).group(1)
    assert (
        tuple(re.findall(r"double (\w+);", struct))
        == FIELD_NAMES
        == TABLE_PARAMETERS
        == tuple(name for name, _ in ColumnConstants._fields_)
    )
    assert not any("ColumnConstants;" in path.read_text() for path in build.DEFAULT_MODEL_DIR.glob("*.h"))


@pytest.mark.parametrize("which", ["fmi2", "fmi3"])
def test_the_documentation_says_to_set_the_rule_by_its_code_with_the_materials(fmu_path, fmu3_path, which):
    page = _read(fmu_path if which == "fmi2" else fmu3_path, "documentation/index.html")
    assert "Set <code>diagonal_rule</code> by its code (0 = receiver, 1 = mean:" in page
    if which == "fmi2":
        assert "<code>material[1]</code> ...\n<code>material[11]</code>" in page
    else:
        assert "the array\n<code>material</code> (11 values)" in page


@pytest.mark.parametrize(
    "argv, says",
    [
        (["--cols", "0"], "--cols must be at least 1"),
        (["--rows", "0", "--cols", "0", "--depth", "0"], "--rows must be at least 1"),
        (["--depth", "0"], "--depth must be at least 1"),
        (["--load-patch", "-1"], "--load-patch must be at least 0"),
        (["--fmi-version", "4"], "--fmi-version: invalid choice"),
    ],
)
def test_the_build_refuses_a_value_it_would_not_build_in_one_line(argv, says, tmp_path, capsys):
    """build_fmu.py's options follow the study's option rules: a size of 0 is refused, not read as the scene's."""
    with pytest.raises(SystemExit) as exit_code:
        build_fmu.main([*argv, "-o", str(tmp_path / "never.fmu")])
    error = capsys.readouterr().err
    assert exit_code.value.code == 2 and says in error and error.count("\n") == 1, error
    assert not (tmp_path / "never.fmu").exists()
