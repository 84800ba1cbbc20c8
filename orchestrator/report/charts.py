"""The report's charts, drawn from a study's typed results (nothing here simulates)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


METHOD_NAMES = {"cmaes": "CMA-ES", "pso": "particle swarm", "sa": "simulated annealing", "ga": "genetic algorithm",
                "de": "differential evolution", "random": "random search", "local": "iterated local search",
                "sequential": "baseline order", "nsga2": "NSGA-II"}
COLOURS = {"cmaes": "tab:blue", "pso": "tab:orange", "sa": "tab:green", "ga": "tab:purple", "de": "tab:brown",
           "random": "tab:gray", "local": "tab:olive", "sequential": "black", "nsga2": "tab:blue"}
RULE_COLOURS = ("tab:blue", "tab:red", "tab:green", "tab:purple")


def save(figure, path: Path, tight: bool = True) -> str:
    if tight:
        figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path.name


def best_so_far_matrix(runs) -> np.ndarray:
    """Rows: seeds; columns: evaluations; NaN before the first value and the last value after a run ended."""
    length = max(run.n_evaluations for run in runs)
    matrix = np.full((len(runs), length), np.nan)
    for row, run in enumerate(runs):
        curve = [np.nan if v is None else v for v in run.best_so_far()]
        matrix[row, :len(curve)] = curve
        if curve:
            matrix[row, len(curve):] = curve[-1]
    return matrix


def wrapped(text: str, width: int = 150) -> str:
    """A chart title over several lines."""
    import textwrap

    return "\n".join(textwrap.wrap(text, width))


__all__ = ["COLOURS", "METHOD_NAMES", "RULE_COLOURS", "best_so_far_matrix", "plt", "save", "wrapped"]
