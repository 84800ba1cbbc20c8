"""Material tables: the study's, and the designer's own, as data.

A table has one row per material: ``name, k, k_diag, c, alpha, alpha_diag`` (docs/model.md sections 3 and 9:
k and k_diag in N, c in N s/m, alpha and alpha_diag in 1/m). Column j of the lattice holds material
``material[j]`` (1-based row of the table). The FMU is built with the table's values as the start values of
its parameter arrays ``k[1..M]``, ``k_diag[1..M]``, ``c[1..M]``, ``alpha[1..M]``, ``alpha_diag[1..M]``.

The study's table is computed here and only here, with Python floats, so the FMU's start values, the
reference model and every test see the same bits on every CPU (numpy's vectorised power can differ from
Python's ``**`` by an ulp, depending on the CPU's instruction set).

    study_materials(11)                  # the study's eleven materials
    load_materials("my_materials.csv")   # a designer's table (.csv, .toml or .json)
"""
from __future__ import annotations

import csv
import hashlib
import json
import math
import tomllib
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, Iterable

MAX_MATERIALS = 256
STUDY_MATERIAL_COUNT = 11  # docs/model.md §3: the study's table; a lattice wider than it has no study material to add


@dataclass(frozen=True)
class Field:
    """One numeric column of a material table and what the model allows for it."""

    name: str
    unit: str
    description: str
    positive: bool  # True: the model needs > 0 (an exponent); False: >= 0 is allowed

    def allowed(self) -> str:
        return "a finite number > 0" if self.positive else "a finite number >= 0"


FIELDS = (
    Field("k", "N", "vertical spring constant", positive=False),
    Field("k_diag", "N", "diagonal spring constant", positive=False),
    Field("c", "N.s/m", "vertical damping", positive=False),
    Field("alpha", "1/m", "vertical spring exponent", positive=True),
    Field("alpha_diag", "1/m", "diagonal spring exponent", positive=True),
)
FIELD_NAMES = tuple(f.name for f in FIELDS)
HEADER = ("name",) + FIELD_NAMES


class MaterialTableError(ValueError):
    """A material table that cannot be used; the message names the file, the row and the field."""


@dataclass(frozen=True)
class Material:
    name: str
    k: float
    k_diag: float
    c: float
    alpha: float
    alpha_diag: float


@dataclass(frozen=True)
class MaterialTable:
    """M materials; ``materials[m - 1]`` is material number m."""

    materials: tuple[Material, ...]

    def __post_init__(self):
        check_rows([{f.name: getattr(m, f.name) for f in fields(Material)} for m in self.materials], "materials")

    def __len__(self) -> int:
        return len(self.materials)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.materials)

    def name_of(self, number: int) -> str:
        """The name of material ``number`` (1-based)."""
        return self.materials[number - 1].name

    def column(self, field: str) -> tuple[float, ...]:
        return tuple(getattr(m, field) for m in self.materials)

    def parameters(self) -> dict[str, tuple[float, ...]]:
        """The FMU's parameter arrays: ``{"k": (k of material 1, ...), "k_diag": ..., ...}``."""
        return {field: self.column(field) for field in FIELD_NAMES}

    def rows(self) -> list[dict[str, Any]]:
        """JSON-ready rows (results.json, the report)."""
        return [{f.name: getattr(m, f.name) for f in fields(Material)} for m in self.materials]

    def sha256(self) -> str:
        """A fingerprint of the table's names and values (exact float bits), for journals and file names."""
        text = json.dumps([[m.name] + [float(getattr(m, f)).hex() for f in FIELD_NAMES] for m in self.materials])
        return hashlib.sha256(text.encode()).hexdigest()

    @classmethod
    def from_rows(cls, rows: Iterable[dict[str, Any]], source: str = "materials") -> "MaterialTable":
        rows = list(rows)
        check_rows(rows, source)
        return cls(tuple(Material(str(r["name"]).strip(), *(float(r[f]) for f in FIELD_NAMES)) for r in rows))


def study_materials(count: int = STUDY_MATERIAL_COUNT) -> MaterialTable:
    """docs/model.md section 3: material m has scale s = (2/3)^(m-1): k = 100 s, k_diag = 50 s, c = 5 s, alpha = 10; the
    first ``count`` of the study's eleven (never more: a twelfth would be invented, not the study's)."""
    if isinstance(count, bool) or int(count) != count or not 1 <= count <= STUDY_MATERIAL_COUNT:
        raise ValueError(f"count must be an integer in [1, {STUDY_MATERIAL_COUNT}] (the study's table has "
                         f"{STUDY_MATERIAL_COUNT} materials), got {count!r}")
    materials = []
    for m in range(1, int(count) + 1):
        scale = (2.0 / 3.0) ** (m - 1)
        materials.append(Material(f"m{m}", 100.0 * scale, 50.0 * scale, 5.0 * scale, 10.0, 10.0))
    return MaterialTable(tuple(materials))


def check_rows(rows: list[dict[str, Any]], source: str) -> None:
    """Every row has a unique non-empty name and every field in its range; else one line naming row and field."""
    if not rows:
        raise MaterialTableError(f"{source}: no materials (expected a header {','.join(HEADER)} and one row per "
                                 "material)")
    if len(rows) > MAX_MATERIALS:
        raise MaterialTableError(f"{source}: {len(rows)} materials; at most {MAX_MATERIALS} are allowed")
    seen: dict[str, int] = {}
    for number, row in enumerate(rows, start=1):
        if not isinstance(row, dict):
            raise MaterialTableError(f"{source}: row {number}: expected the fields {', '.join(HEADER)}")
        unknown = sorted(set(row) - set(HEADER))
        if unknown:
            raise MaterialTableError(f"{source}: row {number}: unknown field {unknown[0]!r}; allowed: "
                                     f"{', '.join(HEADER)}")
        name = row.get("name")
        if not isinstance(name, str) or not name.strip():
            raise MaterialTableError(f"{source}: row {number}, field name: missing (every material needs a name)")
        name = name.strip()
        if name in seen:
            raise MaterialTableError(f"{source}: row {number}, field name: {name!r} is also the name of row "
                                     f"{seen[name]}; names must be unique")
        seen[name] = number
        for field in FIELDS:
            value = row.get(field.name)
            label = f"{source}: row {number} ({name}), field {field.name}"
            if value is None or (isinstance(value, str) and not value.strip()):
                raise MaterialTableError(f"{label}: missing; allowed: {field.allowed()} ({field.unit})")
            if isinstance(value, bool):
                raise MaterialTableError(f"{label}: {value!r} is not a number; allowed: {field.allowed()}")
            try:
                number_value = float(value)
            except (TypeError, ValueError):
                raise MaterialTableError(f"{label}: {value!r} is not a number; allowed: {field.allowed()} "
                                         f"({field.unit})") from None
            if not math.isfinite(number_value) or number_value < 0 or (field.positive and number_value == 0):
                raise MaterialTableError(f"{label}: {value!r} is not allowed; allowed: {field.allowed()} "
                                         f"({field.unit})")


def load_materials(path: str | Path) -> MaterialTable:
    """A material table from a .csv (header ``name,k,k_diag,c,alpha,alpha_diag``), .toml (``[[material]]``
    tables) or .json (a list of objects, or ``{"materials": [...]}``) file; checked before any use."""
    path = Path(path)
    source = str(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise MaterialTableError(f"{source}: cannot be read ({getattr(exc, 'strerror', None) or exc})") from None
    suffix = path.suffix.lower()
    if suffix == ".csv":
        rows = _csv_rows(text, source)
    elif suffix == ".toml":
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise MaterialTableError(f"{source}: not valid TOML ({exc})") from None
        rows = data.get("material")
        if not isinstance(rows, list) or set(data) - {"material"}:
            raise MaterialTableError(f"{source}: expected only [[material]] tables with the fields "
                                     f"{', '.join(HEADER)}")
    elif suffix == ".json":
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise MaterialTableError(f"{source}: not valid JSON ({exc})") from None
        rows = data.get("materials") if isinstance(data, dict) else data
        if not isinstance(rows, list):
            raise MaterialTableError(f'{source}: expected a list of materials or {{"materials": [...]}}')
    else:
        raise MaterialTableError(f"{source}: unknown file type {path.suffix or '(none)'!r}; allowed: .csv, .toml, "
                                 ".json")
    return MaterialTable.from_rows(rows, source)


def _csv_rows(text: str, source: str) -> list[dict[str, Any]]:
    lines = [line for line in text.splitlines() if line.strip() and not line.lstrip().startswith("#")]
    reader = csv.reader(lines)
    try:
        header = [h.strip() for h in next(reader)]
    except StopIteration:
        raise MaterialTableError(f"{source}: empty; expected a header {','.join(HEADER)}") from None
    missing = [h for h in HEADER if h not in header]
    if missing or len(set(header)) != len(header):
        raise MaterialTableError(f"{source}: the header must name each of {','.join(HEADER)} once "
                                 f"(got {','.join(header)})")
    rows = []
    for number, cells in enumerate(reader, start=1):
        if len(cells) != len(header):
            raise MaterialTableError(f"{source}: row {number}: {len(cells)} fields, the header has {len(header)}")
        rows.append(dict(zip(header, (c.strip() for c in cells))))
    return rows


def write_materials_csv(table: MaterialTable, path: str | Path) -> Path:
    """The table as a CSV file that ``load_materials`` reads back exactly (floats written by repr)."""
    path = Path(path)
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(HEADER)
        for m in table.materials:
            writer.writerow([m.name] + [repr(float(getattr(m, f))) for f in FIELD_NAMES])
    return path


__all__ = ["FIELDS", "FIELD_NAMES", "HEADER", "MAX_MATERIALS", "Material", "MaterialTable", "MaterialTableError",
           "STUDY_MATERIAL_COUNT", "load_materials", "study_materials", "write_materials_csv"]
