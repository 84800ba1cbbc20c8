"""The report's charts, drawn from a study's typed results (nothing here simulates)."""
from __future__ import annotations

import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from fmu_src.published import REFERENCE_POINTS  # noqa: E402

METHOD_NAMES = {"cmaes": "CMA-ES", "pso": "particle swarm", "sa": "simulated annealing", "ga": "genetic algorithm",
                "de": "differential evolution", "random": "random search", "local": "iterated local search",
                "sequential": "baseline order", "nsga2": "NSGA-II"}
COLOURS = {"cmaes": "tab:blue", "pso": "tab:orange", "sa": "tab:green", "ga": "tab:purple", "de": "tab:brown",
           "random": "tab:gray", "local": "tab:olive", "sequential": "black", "nsga2": "tab:blue"}
RULE_COLOURS = ("tab:blue", "tab:red", "tab:green", "tab:purple")


def _save(figure, path: Path, tight: bool = True) -> str:
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


def convergence(study, path: Path, context_line: str, known: dict) -> str | None:
    """Best value so far against evaluations, median and quartiles over seeds, one panel per rule."""
    searches = study.steps.get("searches")
    if searches is None or not searches.runs:
        return None
    labels = list(dict.fromkeys(run.label for run in searches.runs))
    figure, axes = plt.subplots(1, len(labels), figsize=(6.5 * len(labels), 4.8), squeeze=False)
    unit = study.case.objective.units[0]
    for axis, label in zip(axes[0], labels):
        runs = [r for r in searches.runs if r.label == label and r.n_evaluations]
        for method in dict.fromkeys(r.method for r in runs):
            own = [r for r in runs if r.method == method]
            matrix = best_so_far_matrix(own)
            if not np.isfinite(matrix).any():  # every evaluation failed: nothing to draw
                continue
            with np.errstate(all="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                median = np.nanmedian(matrix, axis=0)
                low, high = np.nanpercentile(matrix, 25, axis=0), np.nanpercentile(matrix, 75, axis=0)
            name = f"{METHOD_NAMES.get(method, method)} (median of {len(own)})"
            colour = COLOURS.get(method)
            if len(median) == 1:
                axis.axhline(median[-1], color=colour or "black", lw=1, ls=":", label=f"{name}: one design")
                continue
            x = np.arange(1, matrix.shape[1] + 1)
            axis.plot(x, median, color=colour, label=name)
            if len(own) > 1:
                axis.fill_between(x, low, high, color=colour, alpha=0.2, lw=0)
        optimum = known.get(label)
        if optimum is not None:
            axis.axhline(optimum.peak, color="crimson", lw=1, ls="--",
                         label=f"{'certified' if optimum.certified else 'known'} optimum: {optimum.peak:.2f} {unit}")
        if study.case.objective.outputs == ("peak_backplate_force",) and label == "receiver" and known.get(label):
            for point, marker in zip(REFERENCE_POINTS, "o^sD"):
                axis.plot([point.evaluation or 100], [point.peak], marker=marker, color="crimson", ls="none",
                          label=f"published {point.label}: {point.peak:.2f} N")
        if axis.lines:
            axis.set_xscale("log")
        else:
            axis.text(0.5, 0.5, "no evaluation gave a value", ha="center", transform=axis.transAxes)
        axis.set_xlabel("evaluations (distinct designs)")
        axis.set_ylabel(f"best {study.case.objective.outputs[0]} so far ({unit}), search fidelity")
        axis.set_title(f"{label} diagonal rule", fontsize=9)
        axis.grid(alpha=0.3)
        axis.legend(fontsize=7)
    figure.suptitle(f"Convergence over seeds: median and quartiles. {context_line}", fontsize=9)
    return _save(figure, path)


def force_and_energy(study, path: Path, context_line: str) -> str | None:
    trajectories = study.steps.get("trajectories")
    if trajectories is None:
        return None
    figure, (force_axis, energy_axis) = plt.subplots(1, 2, figsize=(13, 4.8))
    colours = ["tab:blue", "tab:red", "black", "tab:gray", "tab:green"]
    for labelled, colour in zip(trajectories.force, colours):
        t = labelled.trajectory
        if not t.ok:
            continue
        force = np.array(t.values["backplate_force"])
        time = np.array(t.time)
        samples = np.abs(time / 0.01 - np.round(time / 0.01)) < 1e-6
        sampled = force[samples].max() if samples.any() else float("nan")
        force_axis.plot(time, force, color=colour,
                        label=f"{labelled.label} {list(t.order)}: peak {force.max():.1f} N every 1 ms, "
                              f"{sampled:.1f} N at the 0.01 s samples")
    force_axis.set_xlabel("time (s)")
    force_axis.set_ylabel("backplate force (N)")
    force_axis.set_title(f"Force on the backplate ({trajectories.force[0].diagonal_rule if trajectories.force else ''}"
                         f" rule), recorded every 1 ms", fontsize=9)
    force_axis.grid(alpha=0.3)
    if force_axis.get_legend_handles_labels()[0]:
        force_axis.legend(fontsize=7)
    names = {"kinetic_energy": "KE", "potential_energy": "PE", "external_work": "W_ext",
             "dissipated_energy": "D", "nonreciprocal_work": "W_nr", "energy_balance_error": "balance error"}
    if trajectories.energy and trajectories.energy[0].trajectory.ok:
        first = trajectories.energy[0]
        for name, values in first.trajectory.values.items():
            energy_axis.plot(first.trajectory.time, values, ":" if name == "energy_balance_error" else "-",
                             label=names.get(name, name))
        energy_axis.set_title(f"Energy of the {first.label} ({first.diagonal_rule} rule): "
                              "W_ext + W_nr = KE + PE + D", fontsize=9)
        energy_axis.legend(fontsize=7)
    energy_axis.set_xlabel("time (s)")
    energy_axis.set_ylabel("energy (J)")
    energy_axis.grid(alpha=0.3)
    figure.suptitle(context_line, fontsize=9)
    return _save(figure, path)


def lattice(study, path: Path) -> str | None:
    answers = study.steps.get("answers")
    if answers is None or not answers.answers:
        return None
    case = study.case
    materials = case.materials
    designs = [(f"{a.diagonal_rule} rule's answer", a.order) for a in answers.answers]
    figure, axes = plt.subplots(1, len(designs), figsize=(4.6 * len(designs), 4.4), squeeze=False)
    stiffness = np.array([m["k"] for m in materials])
    colour_map = plt.get_cmap("viridis")
    norm = matplotlib.colors.Normalize(vmin=float(stiffness.min()), vmax=float(stiffness.max()) or 1.0)
    for axis, (label, order) in zip(axes[0], designs):
        x, y = np.meshgrid(np.arange(case.columns), np.arange(case.rows))
        k = np.tile(np.array([materials[m - 1]["k"] for m in order]), (case.rows, 1))
        axis.scatter(x, y, c=k, cmap=colour_map, norm=norm, s=55, edgecolors="k", lw=0.3)
        axis.axvline(case.columns - 1 + 0.5, color="dimgray", lw=4)
        axis.annotate("", xy=(-0.2, case.rows / 2 - 0.5), xytext=(-1.2, case.rows / 2 - 0.5),
                      arrowprops=dict(arrowstyle="->", lw=2, color="crimson"))
        axis.set_title(label, fontsize=9)
        axis.set_xticks(range(case.columns))
        axis.set_xticklabels([materials[m - 1]["name"] for m in order], fontsize=7, rotation=60)
        axis.set_yticks([])
        axis.set_xlim(-1.5, case.columns + 0.2)
    bar = figure.colorbar(matplotlib.cm.ScalarMappable(norm=norm, cmap=colour_map), ax=axes[0].tolist())
    bar.set_label("vertical spring constant k of the column's material (N)")
    figure.suptitle("Load from the left on column 1, backplate on the right (grey bar)", fontsize=9)
    return _save(figure, path, tight=False)


def work_precision(study, path: Path) -> str | None:
    result = study.steps.get("work_precision")
    if result is None:
        return None
    figure, axis = plt.subplots(figsize=(8, 5))
    families = list(dict.fromkeys(p.solver for p in result.points))
    for family, colour in zip(families, ("tab:blue", "tab:orange", "tab:green")):
        good = [p for p in result.points if p.solver == family and p.relative_error is not None]
        bad = [p for p in result.points if p.solver == family and p.relative_error is None]
        axis.plot([p.seconds for p in good], [max(p.relative_error, 1e-16) for p in good], "o-", color=colour,
                  label=family)
        for p in good:
            axis.annotate(p.setting, (p.seconds, max(p.relative_error, 1e-16)), fontsize=6,
                          textcoords="offset points", xytext=(3, 3))
        if bad:
            axis.plot([max(p.seconds, 1e-5) for p in bad], [1.0] * len(bad), "x", color=colour, ms=9,
                      label=f"{family}: failed with an FMI error ({', '.join(p.setting for p in bad)})")
    axis.axhline(result.target, color="crimson", ls="--", lw=1, label=f"{result.target:g}: the accuracy target")
    if any(p.relative_error is not None for p in result.points):
        axis.set_xscale("log")
        axis.set_yscale("log")
    axis.set_xlabel("seconds per run of the full scene (this machine, during the study)")
    axis.set_ylabel("relative error of the peak against rtol 1e-12")
    axis.set_title(f"Each solver setting of the FMU for the chosen design ({result.diagonal_rule} rule)", fontsize=9)
    axis.grid(alpha=0.3, which="both")
    axis.legend(fontsize=7)
    return _save(figure, path)


def exhaustive(study, path: Path) -> str | None:
    result = study.steps.get("exhaustive")
    if result is None:
        return None
    figure, axes = plt.subplots(1, len(result.sweeps), figsize=(7 * len(result.sweeps), 4.5), squeeze=False)
    unit = study.case.objective.units[0]
    for axis, sweep in zip(axes[0], result.sweeps):
        bins = sweep.histogram
        certificate = sweep.certificate
        if bins:
            lefts = np.array([(1 + sweep.histogram_resolution) ** k for k, _ in bins])
            axis.bar(lefts, [v for _, v in bins], width=lefts * sweep.histogram_resolution, align="edge",
                     color="tab:gray", label=f"{certificate.screened:,} designs screened to a value"
                     + (f"; {certificate.censored:,} more stopped above the force limit (censored)"
                        if certificate.censored else ""))
        if certificate.optimum:
            axis.axvline(certificate.optimum.full, color="crimson", lw=2,
                         label=f"optimum {list(certificate.optimum.order)}: {certificate.optimum.full:.4f} {unit}")
        if bins:
            axis.set_yscale("log")
        axis.set_xlabel(f"{study.case.objective.outputs[0]} ({unit}), screening fidelity")
        axis.set_ylabel("designs")
        axis.set_title(f"Every design's value, {sweep.diagonal_rule} rule", fontsize=9)
        axis.legend(fontsize=7)
        axis.grid(alpha=0.3)
    return _save(figure, path)


def pareto(study, path: Path) -> str | None:
    result = study.steps.get("pareto")
    if result is None:
        return None
    outputs = study.case.objective.outputs
    units = study.case.objective.units
    figure, axis = plt.subplots(figsize=(8, 5.5))
    for front, colour in zip(result.fronts, RULE_COLOURS):
        if front.evaluated:
            points = np.array([p.values for p in front.evaluated])
            axis.plot(points[:, 0], points[:, 1], ".", color=colour, alpha=0.15, ms=3,
                      label=f"every design evaluated ({front.diagonal_rule} rule, search fidelity)")
        if front.points:
            values = np.array(sorted(p.values for p in front.points))
            axis.plot(values[:, 0], values[:, 1], "o-", color=colour, ms=4,
                      label=f"non-dominated set, full fidelity ({front.diagonal_rule} rule)")
            for chosen in front.chosen:
                axis.annotate(chosen.label, chosen.values[:2], fontsize=7, textcoords="offset points",
                              xytext=(5, 5))
    axis.set_xlabel(f"{outputs[0]} ({units[0]})")
    axis.set_ylabel(f"{outputs[1]} ({units[1]})")
    axis.set_title("The trade-off: each point a design; lower is better on both axes", fontsize=9)
    axis.grid(alpha=0.3)
    axis.legend(fontsize=7)
    return _save(figure, path)


__all__ = ["convergence", "exhaustive", "force_and_energy", "lattice", "pareto", "work_precision"]
