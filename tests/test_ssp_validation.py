"""Design files are checked against the FMU's model description, in both directions.

Crafted parameter sets (out of range, not finite, duplicated, incomplete, wrongly typed, not a design, ...)
replace the .ssv of a valid design file; `read_design_parameters` refuses each in one line that names the
parameter. The writer refuses the same values before writing, names the materials, and refuses a design
that libcosim would silently run differently.
"""

from __future__ import annotations

import zipfile
from xml.sax.saxutils import quoteattr

import pytest

from fmu_src.materials import Material, MaterialTable, study_materials
from fmu_src.published import STUDY_BEST_ORDER as PUBLISHED_BEST
from orchestrator.ssp import SSD_NAME, SSV_NAME, design_refusal, read_design_parameters, write_best_design_ssp

BASE = [(f"material[{j}]", "Integer", str(m)) for j, m in enumerate(PUBLISHED_BEST, 1)] + [
    ("F_total", "Real", "1100.0"),
    ("diagonal_rule", "Integer", "0"),
]


def replaced(name, kind, value):
    return [(n, kind, value) if n == name else (n, k, v) for n, k, v in BASE]


def added(*entries):
    return BASE + list(entries)


def without(name):
    return [entry for entry in BASE if entry[0] != name]


# (the parameter the refusal must name, the crafted parameter set, what the message says about it)
CRAFTED = {
    "material above M": ("material[3]", replaced("material[3]", "Integer", "12"), "outside its range"),
    "material zero": ("material[3]", replaced("material[3]", "Integer", "0"), "outside its range"),
    "material negative": ("material[4]", replaced("material[4]", "Integer", "-7"), "outside its range"),
    "material not an integer": ("material[5]", replaced("material[5]", "Integer", "2.5"), "not an integer"),
    "material as hex": ("material[5]", replaced("material[5]", "Integer", "0x3"), "not an integer"),
    "material as Real": ("material[6]", replaced("material[6]", "Real", "6.0"), "given as Real"),
    "material repeated": ("material[2]", replaced("material[2]", "Integer", "1"), "repeats material[1]"),
    "material missing": ("material[11]", without("material[11]"), "missing"),
    "material given twice": ("material[2]", added(("material[2]", "Integer", "7")), "given twice"),
    "material beyond the columns": ("material[12]", added(("material[12]", "Integer", "12")), "not a parameter"),
    "force NaN": ("F_total", replaced("F_total", "Real", "NaN"), "finite"),
    "force infinite": ("F_total", replaced("F_total", "Real", "INF"), "finite"),
    "force not a number": ("F_total", replaced("F_total", "Real", "heavy"), "not a number"),
    "force as Integer": ("F_total", replaced("F_total", "Integer", "1100"), "given as Integer"),
    "force as String": ("F_total", replaced("F_total", "String", "1100"), "given as String"),
    "force far below its range": ("F_total", replaced("F_total", "Real", "-1e300"), "outside its range"),
    "force above its range": ("F_total", replaced("F_total", "Real", "1e300"), "outside its range"),
    "tolerance below its minimum": ("rtol", added(("rtol", "Real", "1e-20")), "outside its range"),
    "angle above its maximum": ("load_angle", added(("load_angle", "Real", "400.0")), "outside its range"),
    "negative mass": ("mass[3]", added(("mass[3]", "Real", "-1.0")), "outside its range"),
    "flag out of range": ("use_symmetry", added(("use_symmetry", "Integer", "2")), "outside its range"),
    "flag as Boolean": ("use_symmetry", added(("use_symmetry", "Boolean", "true")), "given as Boolean"),
    "rule not an item": (
        "diagonal_rule",
        replaced("diagonal_rule", "Integer", "2"),
        "allowed values are 0 (receiver), 1 (mean)",
    ),
    "rule as ssv:Enumeration": ("diagonal_rule", replaced("diagonal_rule", "Enumeration", "mean"), "libcosim"),
    "solver not an item": ("solver", added(("solver", "Integer", "9")), "allowed values are"),
    "unknown name": ("stiffness", added(("stiffness", "Real", "1.0")), "not a parameter"),
    "an output": ("peak_backplate_force", added(("peak_backplate_force", "Real", "1.0")), "not a parameter"),
}


def ssv_text(entries) -> str:
    lines = [
        f"    <ssv:Parameter name={quoteattr(name)}><ssv:{kind} value={quoteattr(value)}/></ssv:Parameter>"
        for name, kind, value in entries
    ]
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" '
        'version="1.0" name="crafted">\n  <ssv:Parameters>\n'
        + "\n".join(lines)
        + "\n  </ssv:Parameters>\n</ssv:ParameterSet>\n"
    )


@pytest.fixture(scope="module")
def design_ssp(fmu_path, tmp_path_factory):
    return write_best_design_ssp(
        fmu_path,
        {"material": list(PUBLISHED_BEST), "F_total": 1100.0, "diagonal_rule": "receiver"},
        tmp_path_factory.mktemp("ssp") / "best_design.ssp",
        stop_time=1.0,
        materials=study_materials(11),
    )


def with_parameter_set(design_ssp, path, text: str):
    with zipfile.ZipFile(design_ssp) as source, zipfile.ZipFile(path, "w") as target:
        for item in source.infolist():
            target.writestr(item, text.encode() if item.filename == SSV_NAME else source.read(item))
    return path


def test_the_base_parameter_set_is_accepted(design_ssp, tmp_path):
    """The crafted files differ from an accepted one only where they say."""
    values = read_design_parameters(with_parameter_set(design_ssp, tmp_path / "base.ssp", ssv_text(BASE)))
    assert [values[f"material[{j}]"] for j in range(1, 12)] == list(PUBLISHED_BEST)
    assert values["F_total"] == 1100.0 and values["diagonal_rule"] == 0


def test_every_crafted_parameter_set_is_refused_naming_the_parameter(design_ssp, tmp_path):
    assert len(CRAFTED) >= 21
    for case, (name, entries, reason) in CRAFTED.items():
        crafted = with_parameter_set(design_ssp, tmp_path / "crafted.ssp", ssv_text(entries))
        with pytest.raises(ValueError) as refusal:
            read_design_parameters(crafted)
        message = str(refusal.value)
        assert "\n" not in message, case
        assert name in message and reason in message, f"{case}: {message}"


def test_a_broken_archive_is_refused_in_one_line(design_ssp, tmp_path):
    no_fmu = tmp_path / "no_fmu.ssp"
    with zipfile.ZipFile(design_ssp) as source, zipfile.ZipFile(no_fmu, "w") as target:
        for item in source.infolist():
            if not item.filename.endswith(".fmu"):
                target.writestr(item, source.read(item))
    not_xml = with_parameter_set(design_ssp, tmp_path / "not_xml.ssp", "<ssv:ParameterSet")
    not_zip = tmp_path / "not_zip.ssp"
    not_zip.write_text("not an archive")
    for path, reason in (
        (no_fmu, "which is not in the archive"),
        (not_xml, "not well-formed XML"),
        (not_zip, "not an SSP archive"),
    ):
        with pytest.raises(ValueError, match=reason) as refusal:
            read_design_parameters(path)
        assert "\n" not in str(refusal.value)


@pytest.mark.parametrize(
    "parameters, message",
    [
        ({"material": [1, 7, 5, 9, 3, 6, 11, 8, 2, 4]}, r"material\[11\] is missing"),
        ({"material": [1, 7, 5, 9, 3, 6, 11, 8, 2, 4, 4]}, r"material\[11\] = 4 repeats material\[10\]"),
        ({"material": list(PUBLISHED_BEST), "material[3]": 5}, r"material\[3\] is given twice"),
        ({"material": list(PUBLISHED_BEST), "F_total": float("nan")}, "F_total = nan is not allowed"),
        ({"material": list(PUBLISHED_BEST), "rtol": 0.5}, r"rtol = 0.5 is outside its range \[1e-14, 0.1\]"),
        ({"material": list(PUBLISHED_BEST), "use_symmetry": 0.5}, "use_symmetry = 0.5 is not an integer"),
        ({"material": list(PUBLISHED_BEST), "use_symmetry": True}, "use_symmetry = True is not an integer"),
        ({"material": list(PUBLISHED_BEST), "F_total": "1100"}, "F_total = '1100' is not a number"),
        ({"material": list(PUBLISHED_BEST), "solver": "euler"}, r"solver = 'euler' is not allowed: allowed values"),
    ],
)
def test_the_writer_refuses_what_the_reader_would(fmu_path, tmp_path, parameters, message):
    with pytest.raises(ValueError, match=message):
        write_best_design_ssp(fmu_path, parameters, tmp_path / "refused.ssp", stop_time=1.0)
    assert not list(tmp_path.iterdir())  # nothing written, not even a partial file


def test_the_parameter_set_names_the_materials_of_the_fmus_table(design_ssp, fmu_path, tmp_path):
    text = zipfile.ZipFile(design_ssp).read(SSV_NAME).decode()
    assert 'name="material[2]" description="column 2: material 7 (m7)"' in text
    assert 'name="diagonal_rule" description="diagonal_rule = receiver"' in text
    other = MaterialTable(study_materials(11).materials + (Material("m12", 1.0, 0.5, 0.05, 10.0, 10.0),))
    with pytest.raises(ValueError, match="the table has 12 materials, the FMU's has 11"):
        write_best_design_ssp(
            fmu_path, {"material": list(PUBLISHED_BEST)}, tmp_path / "x.ssp", stop_time=1.0, materials=other
        )
    with pytest.raises(ValueError, match=r"k of material 3 \('m3'\) is 44.4\d* in the table, but k\[3\] = 2.0"):
        write_best_design_ssp(
            fmu_path,
            {"material": list(PUBLISHED_BEST), "k[3]": 2.0},
            tmp_path / "x.ssp",
            stop_time=1.0,
            materials=study_materials(11),
        )


def with_enumeration_rule(fmu_path, path):
    """A copy of the FMU whose FMI 2 model description declares diagonal_rule an Enumeration (its items in the
    declared type DiagonalRule), and nothing else changed: the writer reads the description, it runs nothing."""
    import re

    with zipfile.ZipFile(fmu_path) as source, zipfile.ZipFile(path, "w") as target:
        for item in source.infolist():
            data = source.read(item)
            if item.filename == "modelDescription.xml":
                text, count = re.subn(
                    r'(name="diagonal_rule" [^>]*>\s*)<Integer start="0" min="0" max="1"/>',
                    r'\1<Enumeration declaredType="DiagonalRule" start="0"/>',
                    data.decode(),
                )
                assert count == 1, "the FMU's diagonal_rule is not the Integer this test rewrites"
                data = text.encode()
            target.writestr(item, data)
    return path


def test_a_design_libcosim_would_run_differently_is_refused(fmu_path, tmp_path):
    """libcosim exposes no FMI 2 Enumeration variable: a non-default diagonal_rule would be dropped there."""
    from fmpy import read_model_description

    enumeration_fmu = with_enumeration_rule(fmu_path, tmp_path / "MassSpringLattice.fmu")
    rule = next(v for v in read_model_description(str(enumeration_fmu)).modelVariables if v.name == "diagonal_rule")
    assert rule.type == "Enumeration"
    mean = {"material": list(PUBLISHED_BEST), "diagonal_rule": "mean"}
    with pytest.raises(ValueError, match="diagonal_rule = mean: libcosim ignores FMI 2 Enumeration parameters"):
        write_best_design_ssp(enumeration_fmu, mean, tmp_path / "mean.ssp", stop_time=1.0)
    assert design_refusal(enumeration_fmu, mean).startswith("diagonal_rule = mean: libcosim ignores")
    assert design_refusal(enumeration_fmu, {"material": list(PUBLISHED_BEST)}) is None
    written = write_best_design_ssp(
        enumeration_fmu,
        {"material": list(PUBLISHED_BEST), "diagonal_rule": "receiver"},
        tmp_path / "receiver.ssp",
        stop_time=1.0,
    )  # the default runs the same
    assert read_design_parameters(written)["diagonal_rule"] == 0
    assert design_refusal(fmu_path, mean) is None  # the FMU offers diagonal_rule as an Integer, which libcosim sets


def test_the_system_carries_the_annotations_of_omsimulator_and_libcosim(design_ssp):
    from lxml import etree

    root = etree.fromstring(zipfile.ZipFile(design_ssp).read(SSD_NAME))
    ns = {
        "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
        "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
        "oms": "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd",
        "osp": "https://opensimulationplatform.com/SSP/1.0",
    }
    (master,) = root.findall(
        "ssd:System/ssd:Annotations/ssc:Annotation[@type='org.openmodelica']/oms:Annotations/"
        "oms:SimulationInformation/oms:FixedStepMaster",
        ns,
    )
    assert master.get("description") == "oms-ma" and float(master.get("stepSize")) == 0.01
    (algorithm,) = root.findall(
        "ssd:DefaultExperiment/ssd:Annotations/ssc:Annotation[@type="
        "'com.opensimulationplatform']/osp:Algorithm/osp:FixedStepAlgorithm",
        ns,
    )
    assert float(algorithm.get("baseStepSize")) == 0.01


def with_design_space(design_ssp, path, materials: int, repeat_start: int, entries):
    """A copy of the design file whose FMU declares ``materials`` materials (material[j] in 1..M) and its
    repeat_materials parameter starting at ``repeat_start``, bound to the parameter set ``entries``. Only the
    model description changes: the reader does not run the FMU."""
    import io
    import re

    with zipfile.ZipFile(design_ssp) as source, zipfile.ZipFile(path, "w") as target:
        for item in source.infolist():
            data = source.read(item)
            if item.filename.endswith(".fmu"):
                buffer = io.BytesIO()
                with zipfile.ZipFile(io.BytesIO(data)) as fmu, zipfile.ZipFile(buffer, "w") as copy:
                    for member in fmu.infolist():
                        content = fmu.read(member)
                        if member.filename == "modelDescription.xml":
                            text = re.sub(
                                r'(<Integer start="\d+" min="1" max=")\d+("/>)',
                                rf"\g<1>{materials}\2",
                                content.decode(),
                            )
                            text, found = re.subn(
                                r'(name="repeat_materials"[^>]*>\s*<Integer start=")\d+(")',
                                rf"\g<1>{repeat_start}\2",
                                text,
                            )
                            assert found == 1, "the FMU declares repeat_materials once"
                            content = text.encode()
                        copy.writestr(member, content)
                data = buffer.getvalue()
            elif item.filename == SSV_NAME:
                data = ssv_text(entries).encode()
            target.writestr(item, data)
    return path


def order_entries(order, *extra):
    return [(f"material[{j}]", "Integer", str(m)) for j, m in enumerate(order, 1)] + list(extra)


ARRANGEMENT = (13, 7, 5, 9, 3, 6, 11, 8, 2, 4, 10)  # material 13 of 13, each at most once
REPEATED = (1, 1, 5, 9, 3, 6, 11, 8, 2, 4, 10)
ALLOW_REPEATS = ("repeat_materials", "Integer", "1")


def test_the_order_is_checked_against_the_fmus_design_space(design_ssp, tmp_path):
    def read(materials, repeat_start, entries):
        return read_design_parameters(
            with_design_space(design_ssp, tmp_path / "space.ssp", materials, repeat_start, entries)
        )

    assert read(13, 0, order_entries(ARRANGEMENT))["material[1]"] == 13  # an arrangement of 11 of 13
    with pytest.raises(ValueError, match=r"material\[2\] = 1 repeats material\[1\]: each material at most once"):
        read(13, 0, order_entries(REPEATED))
    assert read(13, 0, order_entries(REPEATED, ALLOW_REPEATS))["repeat_materials"] == 1
    assert read(13, 1, order_entries(REPEATED))["material[2]"] == 1  # the FMU's default allows repeats
    with pytest.raises(ValueError, match=r"material\[1\] = 13 is outside its range \[1, 9\]"):
        read(9, 0, order_entries(ARRANGEMENT))
    with pytest.raises(ValueError, match="9 materials cannot fill 11 columns"):
        read(9, 0, order_entries((1, 2, 3, 4, 5, 6, 7, 8, 9, 1, 2)))
    assert read(9, 0, order_entries((1, 2, 3, 4, 5, 6, 7, 8, 9, 1, 2), ALLOW_REPEATS))["material[11]"] == 2


@pytest.mark.parametrize(
    "name, given, refusal",
    [
        ("rtol", 0.5, "rtol = 0.5 is outside its range [1e-14, 0.1]"),
        (
            "solver",
            "euler",
            "solver = 'euler' is not allowed: allowed values are ['dop853', 'dopri5', 'rk4', 'rkn5', "
            "'semi_implicit_euler', 'tsit5']",
        ),
    ],
)
def test_a_value_is_checked_once_by_its_parameter_wherever_it_comes_from(fmu_path, tmp_path, name, given, refusal):
    """The command line, a design file and Python refuse the same value with the same words: the parameter's own
    type, read from the model description, checks it."""
    from orchestrator.fmu import describe
    from orchestrator.simulation import LatticeFMU

    with pytest.raises(ValueError) as command_line:
        describe(fmu_path, 11).parameters[name].convert(given, "--case")
    with pytest.raises(ValueError) as design_file:
        write_best_design_ssp(
            fmu_path, {"material": list(PUBLISHED_BEST), name: given}, tmp_path / "x.ssp", stop_time=1.0
        )
    assert str(command_line.value) == f"--case {refusal}"
    assert str(design_file.value) == f"parameters: {refusal}"
    if isinstance(given, str):
        with LatticeFMU(fmu_path) as lattice, pytest.raises(ValueError) as python:
            lattice.simulate(PUBLISHED_BEST, horizon=0.01, parameters={name: given})
        assert str(python.value) == refusal
