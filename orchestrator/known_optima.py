"""The known optima (known_optima.json): which design is the optimum of a case, and whether it is certified.

An answer that matches one says so (status ``certified`` or ``known``); every other answer is the best found.
A known optimum holds only for the case it was found on: the study's materials and lattice (its rows, columns
and depth), the study's scene's defaults (its load over the whole face, backplate, sampling), the sampled peak
over the scene's horizon, one diagonal rule and no other parameter or load case.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from fmu_src.materials import study_materials

from .types import Order

TABLE = Path(__file__).with_name("known_optima.json")


@dataclass(frozen=True)
class KnownOptimum:
    rows: int
    columns: int
    objective: str
    diagonal_rule: str
    horizon: float
    order: Order
    peak: float
    certified: bool
    source: str
    command: str
    runner_up: Order | None = None  # the second best design, where the sweep gave it
    runner_up_peak: float | None = None
    depth: int = 1  # masses along z (docs/model.md section 10): 1, the study's 2-D lattice


def known_optima(table: Path | None = None) -> tuple[KnownOptimum, ...]:
    """Every entry of ``table`` (default: known_optima.json), one per case and diagonal rule."""
    return _read(Path(table or TABLE))


@lru_cache(maxsize=4)
def _read(path: Path) -> tuple[KnownOptimum, ...]:
    table = json.loads(path.read_text())
    return tuple(
        KnownOptimum(
            e["rows"],
            e["columns"],
            e["objective"],
            e["diagonal_rule"],
            float(e["horizon"]),
            tuple(e["order"]),
            float(e["peak"]),
            bool(e["certified"]),
            e["source"],
            e["command"],
            tuple(e["runner_up"]["order"]) if "runner_up" in e else None,
            float(e["runner_up"]["peak"]) if "runner_up" in e else None,
            int(e.get("depth", 1)),
        )
        for e in table["optima"]
    )


def known_optimum(case, rule: str) -> KnownOptimum | None:
    """The known optimum of ``case`` (an ``orchestrator.study.Case``) under ``rule``, if there is one: each rule
    has its own entry (the receiver and the mean rule's optima are different designs)."""
    if case.outputs != ("peak_backplate_force",):
        return None
    return known_optimum_of(case, rule, "peak_backplate_force")


def known_optimum_of(case, rule: str, output: str) -> KnownOptimum | None:
    """The known optimum of one of the case's objectives, ``output``, alone: for a case of several objectives,
    the design at that end of the true Pareto front (what a front must never report a point dominated by)."""
    if (
        output not in case.outputs
        or case.parameters
        or case.case_lists
        or case.departures
        or case.space.kind != "permutation"
        or case.materials != study_materials(case.space.materials)
    ):
        return None
    return next(
        (
            k
            for k in known_optima()
            if k.rows == case.rows
            and k.columns == case.columns
            and k.depth == case.depth
            and k.objective == output
            and k.diagonal_rule == rule
            and k.horizon == case.horizon
        ),
        None,
    )


def known_ends(case, rule: str) -> tuple[KnownOptimum, ...]:
    """The known optimum of each of the case's objectives alone (none, one per objective that has one)."""
    return tuple(k for k in (known_optimum_of(case, rule, output) for output in case.outputs) if k is not None)


__all__ = ["KnownOptimum", "TABLE", "known_optima", "known_ends", "known_optimum", "known_optimum_of"]
