"""What the benchmarks share: the designs they measure, the FMU they measure (built fresh from fmu_src/ unless
one is given) and the searches' FMU settings as the orchestrator sets them."""

from __future__ import annotations

import contextlib
import math
import statistics
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

from builder.build import build_fmu
from fmu_src.published import SEQUENTIAL_ORDER, STUDY_BEST_ORDER
from orchestrator.design import DesignSpace
from orchestrator.known_optima import known_optima
from orchestrator.objective import SEARCH, SEARCH_HORIZON, SEARCH_RTOL, FMURun, LatticeObjective

SEQUENTIAL = SEQUENTIAL_ORDER
STUDY_BEST = STUDY_BEST_ORDER
REVERSED = tuple(reversed(SEQUENTIAL_ORDER))
FULL_HORIZON = 8.0  # s: the study's scene
SCREENING_ERROR = 1e-4  # a screening chunk's bound: which designs it keeps (screened_values keeps every value)
BEST_KNOWN = next(k.order for k in known_optima() if k.columns == 11 and k.diagonal_rule == "receiver")


def random_orders(count: int, seed: int, n: int = 11) -> list[tuple[int, ...]]:
    import numpy as np

    rng = np.random.default_rng(seed)
    return [tuple(int(x) + 1 for x in rng.permutation(n)) for _ in range(count)]


def bench_orders(random_count: int = 2, seed: int = 2024) -> dict[str, tuple[int, ...]]:
    """The sequential order, the study's best, the reversed order (the stiffest column last) and random ones."""
    orders = {"sequential": SEQUENTIAL, "study's best": STUDY_BEST, "reversed": REVERSED}
    for k, order in enumerate(random_orders(random_count, seed)):
        orders[f"random {k + 1}"] = order
    return orders


def order_text(order) -> str:
    return "[" + ", ".join(str(m) for m in order) + "]"


def add_fmu_option(parser) -> None:
    parser.add_argument("--fmu", help="the FMU to measure (default: built from fmu_src/ into a temporary folder)")


@contextlib.contextmanager
def lattice_fmu(
    given: str | None = None,
    rows: int | None = None,
    cols: int | None = None,
    scene: str | None = None,
    option: str = "--fmu",
) -> Iterator[Path]:
    """The FMU to measure: the one given (``option`` names it in an error), or the FMU of ``scene`` (default the
    armour scene, resized to rows x cols if given) built now into a folder removed afterwards."""
    if given:
        path = Path(given)
        if not path.is_file():
            raise SystemExit(f"{option}: no such file {given!r}")
        yield path
        return
    with tempfile.TemporaryDirectory(prefix="bench_fmu_") as folder:
        if scene is not None:
            yield build_fmu(scene=scene, output=Path(folder) / f"{scene}.fmu", rows=rows, cols=cols)
            return
        name = "MassSpringLattice.fmu" if rows is None and cols is None else f"Lattice{rows or 11}x{cols or 11}.fmu"
        yield build_fmu(output=Path(folder) / name, rows=rows, cols=cols)


def default_setting(fmu_path) -> dict:
    """The FMU's own default solver settings, as its model description declares them."""
    from orchestrator.fmu import describe

    prepared = describe(Path(fmu_path), 11)
    return {name: prepared.start(name) for name in ("solver", "rtol", "atol")}


def setting_text(setting: dict) -> str:
    return (
        f"{setting['solver'].upper() if setting['solver'] == 'dop853' else setting['solver']}, rtol "
        f"{setting['rtol']:g}, atol {setting['atol']:g}"
    )


def search_parameters(fmu_path, columns: int = 11) -> dict:
    """The FMU parameters of a search evaluation, exactly as the orchestrator's objective sets them."""
    objective = LatticeObjective(fmu_path, DesignSpace.permutations(columns), FULL_HORIZON)
    return objective.run_parameters({}, SEARCH)


def search_setting_text(parameters: dict) -> str:
    return f"{parameters['solver']} at rtol {parameters['rtol']:g}, atol {parameters['atol']:g}, {SEARCH_HORIZON:g} s"


def geometric_mean(values) -> float:
    values = list(values)
    return math.exp(statistics.fmean(math.log(v) for v in values)) if values else math.nan


def span(values, format_: str = "{:.2f}") -> str:
    """'a-b' over the values (one value when they agree at that precision)."""
    values = list(values)
    low, high = format_.format(min(values)), format_.format(max(values))
    return low if low == high else f"{low}-{high}"


def relative(value: float, reference: float) -> float:
    return abs(value / reference - 1.0) if reference else abs(value - reference)


@dataclass(frozen=True)
class WithoutLimit:
    """An FMU run that never stops early: a chunk given it evaluates every design to its value (a chunk given
    an ``FMURun`` lowers its force limit as its own best improves, and a design above it is censored)."""

    run: FMURun

    @property
    def key(self) -> str:
        return f"{self.run.key}|never limited"

    def __call__(self, order):
        return self.run(order)


# an answer's reported peak against a benchmark's own evaluation of it
AGREEMENT = 1e-9


def check_agrees(label: str, reported: float, computed: float) -> None:
    if abs(reported / computed - 1.0) > AGREEMENT:
        raise SystemExit(f"{label}: the answer reports {reported!r} N, this benchmark computes {computed!r} N")


def percent(value: float, reference: float) -> str:
    return f"{100.0 * (value / reference - 1.0):+.2f}"


def rank_of(order, space: DesignSpace, values: list) -> tuple[int, int]:
    """(1-based rank of ``order`` by screened value, orders screened); failed orders are not counted."""
    mine = values[space.rank(tuple(order))]
    good = [v for v in values if v is not None]
    return 1 + sum(v < mine for v in good), len(good)


def screened_values(
    fmu_path,
    space: DesignSpace,
    workers: int,
    parameters: dict | None = None,
    search_horizon: float = SEARCH_HORIZON,
    search_rtol: float = SEARCH_RTOL,
) -> tuple:
    """Every design's value at the search fidelity (over ``search_horizon`` at ``search_rtol``), in rank order
    (None where it failed): the sweep's screening (``orchestrator.exhaustive.ScreenChunk``, every value kept, no
    force limit) through the Evaluator on a process pool. Only which designs a chunk keeps depends on the
    screening error; every value is kept here."""
    from orchestrator.executors import make_executor
    from orchestrator.exhaustive import ScreenChunk, chunk_ranges
    from orchestrator.loop import Evaluator
    from orchestrator.objective import close_instances

    (screening,) = LatticeObjective(
        str(fmu_path),
        space,
        FULL_HORIZON,
        parameters=parameters or {},
        search_horizon=search_horizon,
        search_rtol=search_rtol,
    ).tasks(SEARCH)
    with make_executor("process", workers) as executor:
        chunks = Evaluator(executor).run(
            [
                ScreenChunk(WithoutLimit(screening), space, a, b, 1, SCREENING_ERROR, None, all_values=True)
                for a, b in chunk_ranges(space.size, max(1, space.size // 100))
            ]
        )
    close_instances()
    bad = [chunk for chunk in chunks if not chunk.ok]
    if bad:
        raise SystemExit(f"{len(bad)} screening chunks failed, first: {bad[0].message}")
    return tuple(value for chunk in chunks for value in chunk.values)


@contextlib.contextmanager
def narrow_lattice(columns: int) -> Iterator[tuple[Path, Path]]:
    """(scene file, FMU) of the study's armour scene with fewer columns (the study's material law with one
    material per column), in a folder removed afterwards: a scene of one's own, as a user would write it."""
    import json

    from scenes import SCENE_DIR

    with tempfile.TemporaryDirectory(prefix="bench_lattice_") as folder:
        scene = json.loads((SCENE_DIR / "armour_11x11.json").read_text())
        scene.update(
            name=f"armour_11x{columns}",
            model_identifier=f"MassSpringLattice11x{columns}",
            cols=columns,
            description=f"The study's armour scene with {columns} columns",
        )
        path = Path(folder) / f"armour_11x{columns}.json"
        path.write_text(json.dumps(scene, indent=1))
        yield path, build_fmu(scene=str(path), output=Path(folder) / f"MassSpringLattice11x{columns}.fmu")


TWELFTH_SCALE = (2.0 / 3.0) ** 11  # the study's law (docs/model.md section 3) one step past its eleventh material


def twelve_materials():
    """A user's table of twelve materials for the 12-column frontier: the study's eleven and a twelfth by the same
    law (k = 100 s, k_diag = 50 s, c = 5 s, alpha = 10 at the next scale s). Not the study's table, which has
    eleven: a benchmark's scenario, named as such on its page."""
    from fmu_src.materials import Material, MaterialTable, study_materials

    s = TWELFTH_SCALE
    return MaterialTable(study_materials().materials + (Material("m12", 100.0 * s, 50.0 * s, 5.0 * s, 10.0, 10.0),))


TWELVE_MATERIALS_TEXT = "the study's 11 materials and a 12th by the same law (scale (2/3)^11), a user's table"


@contextlib.contextmanager
def twelve_column_lattice() -> Iterator[Path]:
    """The armour scene over 12 columns with ``twelve_materials``, built into a folder removed afterwards."""
    with tempfile.TemporaryDirectory(prefix="bench_lattice_") as folder:
        yield build_fmu(output=Path(folder) / "MassSpringLattice11x12.fmu", cols=12, materials=twelve_materials())


__all__ = [
    "BEST_KNOWN",
    "TWELVE_MATERIALS_TEXT",
    "twelve_column_lattice",
    "twelve_materials",
    "default_setting",
    "setting_text",
    "FULL_HORIZON",
    "REVERSED",
    "SEQUENTIAL",
    "STUDY_BEST",
    "add_fmu_option",
    "bench_orders",
    "geometric_mean",
    "lattice_fmu",
    "narrow_lattice",
    "order_text",
    "random_orders",
    "relative",
    "screened_values",
    "search_parameters",
    "search_setting_text",
    "span",
    "WithoutLimit",
]
