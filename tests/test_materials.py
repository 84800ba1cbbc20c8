"""Material tables as data: the study's table in one place, and a designer's table checked before any use."""

import json

import pytest

from fmu_src.materials import (
    HEADER,
    MaterialTable,
    MaterialTableError,
    load_materials,
    study_materials,
    write_materials_csv,
)

pytestmark = pytest.mark.quick  # a first check: python -m pytest -m quick


def test_the_study_table_follows_spec_section_3():
    table = study_materials(11)
    assert len(table) == 11
    assert table.names[0] == "m1" and table.names[-1] == "m11"
    for m, material in enumerate(table.materials, start=1):
        scale = (2.0 / 3.0) ** (m - 1)
        assert material.k == pytest.approx(100 * scale, rel=1e-15)
        assert material.k_diag == pytest.approx(50 * scale, rel=1e-15)
        assert material.c == pytest.approx(5 * scale, rel=1e-15)
        assert material.alpha == material.alpha_diag == 10.0


def test_a_csv_table_round_trips_exactly(tmp_path):
    table = study_materials(4)
    path = write_materials_csv(table, tmp_path / "table.csv")
    assert path.read_text().splitlines()[0] == ",".join(HEADER)
    again = load_materials(path)
    assert again == table
    assert again.sha256() == table.sha256()


def test_a_tables_fingerprint_names_its_bounds_and_only_when_a_row_gives_them():
    """A study file's recorded fingerprint notices a changed co-design bound; a table without bounds keeps the
    fingerprint it has always had."""
    rows = [
        {"name": "foam", "k": 20.0, "k_diag": 10.0, "c": 1.0, "alpha": 8.0, "alpha_diag": 8.0},
        {"name": "steel", "k": 900.0, "k_diag": 450.0, "c": 9.0, "alpha": 12.0, "alpha_diag": 11.0},
    ]
    plain = MaterialTable.from_rows(rows)
    bounded = MaterialTable.from_rows([{**rows[0], "k_min": 10.0, "k_max": 40.0}, rows[1]])
    wider = MaterialTable.from_rows([{**rows[0], "k_min": 10.0, "k_max": 41.0}, rows[1]])
    assert plain.materials == bounded.materials == wider.materials
    assert len({plain.sha256(), bounded.sha256(), wider.sha256()}) == 3
    assert MaterialTable.from_rows([dict(row) for row in rows]).sha256() == plain.sha256()


def test_toml_and_json_give_the_same_table(tmp_path):
    rows = [
        {"name": "foam", "k": 20.0, "k_diag": 10.0, "c": 1.0, "alpha": 8.0, "alpha_diag": 8.0},
        {"name": "steel", "k": 900.0, "k_diag": 450.0, "c": 9.0, "alpha": 12.0, "alpha_diag": 11.0},
    ]
    (tmp_path / "t.json").write_text(json.dumps({"materials": rows}))
    toml = "".join(
        "[[material]]\n" + "".join(f"{k} = {v!r}\n".replace("'", '"') for k, v in row.items()) for row in rows
    )
    (tmp_path / "t.toml").write_text(toml)
    assert load_materials(tmp_path / "t.json") == load_materials(tmp_path / "t.toml")
    assert load_materials(tmp_path / "t.json").names == ("foam", "steel")


@pytest.mark.parametrize(
    "body, expected",
    [
        ("name,k,k_diag,c,alpha\nfoam,1,1,1,1\n", "header must name each of"),
        ("name,k,k_diag,c,alpha,alpha_diag\nfoam,1,1,1,1,1\nfoam,2,2,2,2,2\n", "row 2, field name: 'foam' is also"),
        ("name,k,k_diag,c,alpha,alpha_diag\n,1,1,1,1,1\n", "row 1, field name: missing"),
        ("name,k,k_diag,c,alpha,alpha_diag\nfoam,abc,1,1,1,1\n", "row 1 (foam), field k: 'abc' is not a number"),
        ("name,k,k_diag,c,alpha,alpha_diag\nfoam,1,nan,1,1,1\n", "row 1 (foam), field k_diag: 'nan' is not allowed"),
        ("name,k,k_diag,c,alpha,alpha_diag\nfoam,1,1,-1,1,1\n", "row 1 (foam), field c: '-1' is not allowed"),
        ("name,k,k_diag,c,alpha,alpha_diag\nfoam,1,1,1,0,1\n", "row 1 (foam), field alpha: '0' is not allowed"),
        ("name,k,k_diag,c,alpha,alpha_diag\nfoam,1,1,1,1,inf\n", "field alpha_diag: 'inf' is not allowed"),
        ("name,k,k_diag,c,alpha,alpha_diag\nfoam,1,1,1,1\n", "row 1: 5 fields, the header has 6"),
        ("name,k,k_diag,c,alpha,alpha_diag\nfoam,1,1,,1,1\n", "row 1 (foam), field c: missing"),
        ("name,k,k_diag,c,alpha,alpha_diag\n", "no materials"),
        ("", "empty"),
    ],
)
def test_a_bad_csv_is_refused_in_one_line_naming_row_and_field(tmp_path, body, expected):
    path = tmp_path / "bad.csv"
    path.write_text(body)
    with pytest.raises(MaterialTableError) as caught:
        load_materials(path)
    message = str(caught.value)
    assert expected in message and "\n" not in message and str(path) in message


def test_unknown_suffix_and_unknown_fields_are_refused(tmp_path):
    (tmp_path / "t.xlsx").write_text("x")
    with pytest.raises(MaterialTableError, match="allowed: .csv, .toml, .json"):
        load_materials(tmp_path / "t.xlsx")
    (tmp_path / "t.json").write_text(
        json.dumps([{"name": "a", "k": 1, "k_diag": 1, "c": 1, "alpha": 1, "alpha_diag": 1, "density": 7}])
    )
    with pytest.raises(MaterialTableError, match="unknown field 'density'"):
        load_materials(tmp_path / "t.json")
    with pytest.raises(MaterialTableError, match="cannot be read"):
        load_materials(tmp_path / "missing.csv")


def test_a_table_in_code_is_checked_too():
    with pytest.raises(MaterialTableError, match="no materials"):
        MaterialTable(())
    with pytest.raises(ValueError, match="count must be"):
        study_materials(0)
