"""The report folder of a study: results.json, evaluations.csv, the charts and report.html.

Every number shown is computed here or in the study; the study's published figures appear only as
labelled reference points.
"""
from __future__ import annotations

import csv
import html
import json
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .objective import SEARCH_SOLVER  # noqa: E402
from .simulation import ENERGY_OUTPUTS, LatticeFMU, SimulationError  # noqa: E402
from .search import SEARCHES  # noqa: E402
from .study import STUDY_BEST_ORDER, STUDY_REFERENCE_POINTS, Study  # noqa: E402

METHOD_NAMES = {"cmaes": "CMA-ES", "pso": "particle swarm", "sa": "simulated annealing", "random": "random search",
                "local": "iterated local search",
                "sequential": "sequential order"}
COLOURS = {"cmaes": "tab:blue", "pso": "tab:orange", "sa": "tab:green", "random": "tab:gray", "sequential": "black"}
TIGHT = {"rtol": 1e-12, "atol": 1e-14}


def write_report(study: Study) -> Path:
    out = Path(study.config.out)
    out.mkdir(parents=True, exist_ok=True)
    accuracy = measure_accuracy(study)
    accuracy["work_precision"] = work_precision_points(study, accuracy.get("reference_peak"))
    write_results_json(study, accuracy, out / "results.json")
    write_evaluations_csv(study, out / "evaluations.csv")
    charts = {
        "convergence": plot_convergence(study, out / "convergence.png"),
        "force_energy": plot_force_and_energy(study, out / "force_energy.png"),
        "lattice": plot_lattice(study, out / "lattice.png"),
        "work_precision": plot_work_precision(accuracy["work_precision"], out / "work_precision.png"),
    }
    if study.exhaustive:
        charts["exhaustive"] = plot_exhaustive(study, out / "exhaustive.png")
    write_design(study, out)
    (out / "report.html").write_text(render_html(study, accuracy, charts))
    return out / "report.html"


def write_design(study: Study, out: Path) -> Path | None:
    """best_design.ssp: the FMU with the best order and the run's non-default parameters, for any SSP tool
    (libcosim's from_ssp_file, FMPy's fmpy.ssp). With load cases it holds the base parameters (one case
    set per file)."""
    best = study.best_verified()
    if best is None:
        return None
    from .ssp import write_best_design_ssp

    return write_best_design_ssp(study.fmu_path, {"material": list(best.order), **_parameters(study)},
                                 out / "best_design.ssp", stop_time=study.horizon)


def _parameters(study: Study) -> dict:
    return {k: v for k, v in study.config.parameters.items() if v is not None}


def measure_accuracy(study: Study) -> dict:
    """How far the reported best is from a 1e-12 reference, and from the search's cheaper objective."""
    best = study.best_verified()
    if best is None:
        return {}
    if "cases" in best.details:
        return {"note": "load cases: the accuracy study runs for single-case objectives only"}
    with LatticeFMU(study.fmu_path) as fmu:
        try:
            tight = fmu.simulate(best.order, horizon=study.horizon, parameters={**_parameters(study), **TIGHT})
        except SimulationError as exc:
            return {"error": str(exc)}
        horizons = {}  # the horizon study for the best order: the peak over shorter horizons against the full one
        for horizon in (0.5, 0.75, 1.0, 2.0):
            if horizon < study.horizon:
                try:
                    short = fmu.simulate(best.order, horizon=horizon, parameters=_parameters(study))
                    horizons[horizon] = short["peak_backplate_force"]
                except SimulationError:
                    horizons[horizon] = None
    search_values = [e.peak for run in study.runs for e in run.evaluations if e.ok and e.order == best.order]
    return {
        "order": list(best.order),
        "reference_rtol": TIGHT["rtol"],
        "reference_peak": tight["peak_backplate_force"],
        "sampled_relative_error": relative_difference(best.details["peak_sampled"], tight["peak_backplate_force"]),
        "continuous_relative_error": relative_difference(best.details["peak_continuous"],
                                                         tight["peak_backplate_force_continuous"]),
        "search_objective_relative_difference": (relative_difference(search_values[0], best.peak)
                                                 if search_values else None),
        "sampling_shortfall": (1 - best.details["peak_sampled"] / best.details["peak_continuous"]
                               if best.details["peak_continuous"] else None),
        "peak_by_horizon": {str(h): v for h, v in horizons.items()},
    }


def relative_difference(value: float, reference: float) -> float:
    """|value / reference - 1|, and the absolute difference where the reference is 0 (no load, no peak)."""
    return abs(value / reference - 1) if reference else abs(value - reference)


def results_dict(study: Study, accuracy: dict) -> dict:
    config = study.config
    runs = []
    for run in study.runs:
        answer = study.run_best(run)
        runs.append({
            "method": run.method,
            "seed": run.seed,
            "budget": run.budget,
            "objective": config.objective,
            "best_order": list(answer.order) if answer else None,
            "best_peak": answer.peak if answer else None,
            "best_peak_continuous": answer.details.get("peak_continuous") if answer else None,
            "evaluations": run.n_evaluations,
            "wall_seconds": run.wall_seconds,
            "search_best_order": list(run.best_order) if run.best_order else None,
            "search_best_peak": run.best_peak,
            "search_best_index": run.best_index,
            "failed": run.n_failed,
            "censored": run.n_censored,
            "stalled": run.stalled,
            "stop_reason": run.stop_reason,
            "diagnostics": run.diagnostics,
        })
    best = study.best_verified()
    return {
        "objective": config.objective,
        "objective_description": study.objective.describe(),
        "scene": config.scene,
        "fmu": str(study.fmu_path),
        "horizon": study.horizon,
        "search_horizon": study.search_horizon,
        "search_rtol": config.search_rtol,
        "parameters": _parameters(study),
        "diagonal_rule": _parameters(study).get("diagonal_rule", "receiver"),
        "runs": runs,
        "best": None if best is None else {
            "order": list(best.order), "peak": best.peak, "unit": study.objective.unit,
            "peak_sampled": best.details.get("peak_sampled"), "peak_continuous": best.details.get("peak_continuous"),
            "peak_time": best.details.get("peak_time"), "last_contact_time": best.details.get("last_contact_time"),
            **({"cases": best.details["cases"], "aggregate": best.details.get("aggregate")}
               if "cases" in best.details else {})},
        "cases": study.objective.cases if study.objective.cases != [{}] else [],
        "verified": [{"order": list(v.order), "peak": v.peak, "peak_sampled": v.details.get("peak_sampled"),
                      "peak_continuous": v.details.get("peak_continuous"), "status": v.status, "message": v.message}
                     for v in study.verified.values()],
        "finalist_disagreements": study.finalist_disagreements,
        "local_optimality": study.local_check,
        "exhaustive": study.exhaustive,
        "which_model": study.which_model,
        "sensitivity": study.sensitivity,
        "evaluator": study.evaluator_state,
        "accuracy": accuracy,
        "study_reference_points": STUDY_REFERENCE_POINTS,
        "known_optimum": known_optimum(study),
        "wall_seconds": study.wall_seconds,
    }


def write_results_json(study: Study, accuracy: dict, path: Path) -> None:
    path.write_text(json.dumps(results_dict(study, accuracy), indent=2, default=_json_default))


def _json_default(value):
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (np.floating,)):
        return float(value)
    if isinstance(value, (np.ndarray, tuple)):
        return list(value)
    return str(value)


def write_evaluations_csv(study: Study, path: Path) -> None:
    fields = ["method", "seed", "index", "order", "peak", "status", "seconds", "objective", "peak_sampled",
              "peak_continuous", "horizon", "message"]  # the searches' evaluations; journal.jsonl has them all
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=fields, extrasaction="ignore")
        writer.writeheader()
        for run in study.runs:
            for index, evaluation in enumerate(run.evaluations, start=1):
                details = evaluation.details
                writer.writerow({
                    "method": run.method, "seed": run.seed, "index": index,
                    "order": " ".join(str(m) for m in evaluation.order),
                    "peak": "" if evaluation.peak is None else repr(evaluation.peak),
                    "status": evaluation.status, "seconds": f"{evaluation.seconds:.6f}",
                    "objective": study.config.objective,
                    "peak_sampled": details.get("peak_sampled", ""), "peak_continuous": details.get("peak_continuous", ""),
                    "horizon": details.get("horizon", ""), "message": evaluation.message,
                })


def _save(figure, path: Path, tight: bool = True) -> str:
    """Writes a chart and frees it; the report links it by file name."""
    if tight:
        figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)
    return path.name


def best_so_far_matrix(runs) -> np.ndarray:
    """Rows: seeds; columns: evaluations; NaN before the first good value and after a run ended."""
    length = max(run.n_evaluations for run in runs)
    matrix = np.full((len(runs), length), np.nan)
    for row, run in enumerate(runs):
        curve = [np.nan if v is None else v for v in run.best_so_far()]
        matrix[row, :len(curve)] = curve
        if curve:
            matrix[row, len(curve):] = curve[-1]
    return matrix


def plot_convergence(study: Study, path: Path) -> str:
    figure, axis = plt.subplots(figsize=(8, 5))
    methods = list(dict.fromkeys(run.method for run in study.runs))
    for method in methods:
        runs = [run for run in study.runs if run.method == method and run.n_evaluations]
        if not runs:
            continue
        matrix = best_so_far_matrix(runs)
        x = np.arange(1, matrix.shape[1] + 1)
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a method whose every evaluation failed: NaN
            median = np.nanmedian(matrix, axis=0)
            low, high = np.nanpercentile(matrix, 25, axis=0), np.nanpercentile(matrix, 75, axis=0)
        label = f"{METHOD_NAMES.get(method, method)} (median of {len(runs)})"
        if SEARCHES[method].deterministic:  # one order, whatever the seed: a level, not a curve
            axis.axhline(median[-1], color=COLOURS.get(method, "black"), lw=1, label=f"{label}: one order")
            continue
        axis.plot(x, median, color=COLOURS.get(method), label=label)
        if len(runs) > 1:
            axis.fill_between(x, low, high, color=COLOURS.get(method), alpha=0.2, lw=0)
    known = known_optimum(study)
    if known is not None:
        axis.axhline(known["peak"], color="crimson", lw=1, ls="--",
                     label=("known optimum" if known["proven"] else "best known order (not proven optimal)")
                     + f" {known['order']}: {known['peak']:.2f} N")
    for (name, value), marker in zip(STUDY_REFERENCE_POINTS.items(), "o^sD"):
        x_at = 4 if "evaluation 4" in name else 100
        axis.plot([x_at], [value], marker=marker, color="crimson", ls="none", label=f"{name}: {value:.2f} N")
    axis.set_xlabel("evaluations (distinct orders)")
    axis.set_ylabel(f"best peak backplate force so far (N), {study.config.objective} objective")
    axis.set_title("Convergence: median and quartiles over seeds; search objective "
                   f"({study.search_horizon:g} s horizon)", fontsize=9)
    axis.set_xscale("log")
    axis.grid(alpha=0.3)
    axis.legend(fontsize=7)
    return _save(figure, path)


def known_optimum(study: Study) -> dict | None:
    """The known optimum (orchestrator/known_optima.json) of this run's case, if there is one: same lattice,
    the sampled objective over 8 s, the receiver rule and no other parameter or load case."""
    if (study.config.objective != "sampled" or study.horizon != 8.0 or study.objective.cases != [{}]
            or any(k != "diagonal_rule" for k in _parameters(study)) or study.config.diagonal_rule != "receiver"):
        return None
    columns = study.objective.n_var
    table = json.loads((Path(__file__).parent / "known_optima.json").read_text())
    return next((entry for entry in table["optima"]
                 if entry["columns"] == columns and entry["rows"] == study.rows), None)


def _trajectory(fmu: LatticeFMU, order, horizon, step, parameters):
    names = ("backplate_force",) + ENERGY_OUTPUTS
    return fmu.simulate(order, horizon=horizon, parameters=parameters, communication_step=step,
                        record=names)["trajectory"]


def plot_force_and_energy(study: Study, path: Path) -> str:
    best = study.best_verified()
    columns = len(best.order) if best else 11
    orders = {"best found": best.order if best else None, "sequential": tuple(range(1, columns + 1))}
    if len(STUDY_BEST_ORDER) == columns:
        orders["study's best"] = STUDY_BEST_ORDER
    figure, (force_axis, energy_axis) = plt.subplots(1, 2, figsize=(12, 4.5))
    parameters = _parameters(study)
    with LatticeFMU(study.fmu_path) as fmu:
        for (label, order), colour in zip(orders.items(), ("tab:blue", "black", "crimson")):
            if order is None:
                continue
            try:
                short = _trajectory(fmu, order, min(1.0, study.horizon), 0.001, parameters)
            except SimulationError:
                continue
            force_axis.plot(short.time, short.values["backplate_force"], color=colour,
                            label=f"{label} {list(order)}: peak {short.values['backplate_force'].max():.1f} N")
        if best is not None:
            long = _trajectory(fmu, best.order, study.horizon, 0.01, parameters)
            for name, style in zip(ENERGY_OUTPUTS, ("-", "-", "-", "-", "-", ":")):
                energy_axis.plot(long.time, long.values[name], style, label=name.replace("_", " "))
    force_axis.set_xlabel("time (s)")
    force_axis.set_ylabel("backplate force (N)")
    if force_axis.get_legend_handles_labels()[0]:
        force_axis.legend(fontsize=7)
    force_axis.grid(alpha=0.3)
    energy_axis.set_xlabel("time (s)")
    energy_axis.set_ylabel("energy (J)")
    energy_axis.set_title("energy balance of the best order: W_ext + W_nr = KE + PE + D", fontsize=9)
    if energy_axis.get_legend_handles_labels()[0]:
        energy_axis.legend(fontsize=7)
    energy_axis.grid(alpha=0.3)
    return _save(figure, path)


def plot_lattice(study: Study, path: Path) -> str:
    best = study.best_verified()
    columns = len(best.order) if best else 11
    rows = study.rows
    orders = [("best found", best.order if best else None), ("sequential", tuple(range(1, columns + 1)))]
    if len(STUDY_BEST_ORDER) == columns:
        orders.insert(1, ("study's best", STUDY_BEST_ORDER))
    orders = [(label, order) for label, order in orders if order is not None]
    figure, axes = plt.subplots(1, len(orders), figsize=(4 * len(orders), 4), squeeze=False)
    colour_map = plt.get_cmap("viridis_r")
    for axis, (label, order) in zip(axes[0], orders):
        x, y = np.meshgrid(np.arange(columns), np.arange(rows))
        materials = np.tile(np.array(order), (rows, 1))
        points = axis.scatter(x, y, c=materials, cmap=colour_map, vmin=1, vmax=columns, s=60, edgecolors="k", lw=0.3)
        axis.axvline(columns - 1 + 0.5, color="dimgray", lw=4)
        axis.annotate("", xy=(-0.2, rows / 2 - 0.5), xytext=(-1.2, rows / 2 - 0.5),
                      arrowprops=dict(arrowstyle="->", lw=2, color="crimson"))
        axis.set_title(f"{label}\n{list(order)}", fontsize=8)
        axis.set_xticks(range(columns))
        axis.set_xticklabels(order, fontsize=7)
        axis.set_yticks([])
        axis.set_xlim(-1.5, columns + 0.2)
    figure.colorbar(points, ax=axes[0].tolist(), label="material (1 = stiffest, k = 100 (2/3)^(m-1))")
    return _save(figure, path, tight=False)


# How the report names the searches' solver (orchestrator.objective.SEARCH_SOLVER).
SEARCH_SOLVER_NAME = {"rkn5": "Fine's Runge-Kutta-Nystrom 5(4) pair", "tsit5": "Tsitouras' 5(4) pair",
                      "dopri5": "Dormand-Prince 5(4)", "dop853": "DOP853"}.get(SEARCH_SOLVER, SEARCH_SOLVER)

# The solver settings the report's speed/accuracy chart sweeps, for the best order over the full scene.
SWEEP = ([("DOP853 (adaptive)", "dop853", {"rtol": r, "atol": r * 1e-2}, f"rtol {r:g}")
          for r in (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)]
         + [("RK4 (fixed step)", "rk4", {"fixed_step": h}, f"step {h:g} s") for h in (1e-3, 3e-3, 1e-2, 2e-2, 4e-2)]
         + [("semi-implicit Euler", "semi_implicit_euler", {"fixed_step": h}, f"step {h:g} s")
            for h in (1e-4, 3e-4, 1e-3, 3e-3)])


def work_precision_points(study: Study, reference_peak: float | None) -> list[dict]:
    """Seconds and peak error of each solver setting for the best order, against its rtol 1e-12 peak."""
    import time

    best = study.best_verified()
    if best is None or reference_peak is None:
        return []
    parameters = _parameters(study)
    points = []
    with LatticeFMU(study.fmu_path) as fmu:
        for family, solver, settings, label in SWEEP:
            start = time.perf_counter()
            try:
                result = fmu.simulate(best.order, horizon=study.horizon,
                                      parameters={**parameters, "solver": solver, **settings})
                error = relative_difference(result["peak_backplate_force"], reference_peak)
                status = "ok" if error <= 1e-6 else "inaccurate"
            except SimulationError as exc:
                error, status = None, "failed: " + str(exc).split(": ", 2)[-1][:80]
            points.append({"solver": family, "setting": label, "seconds": time.perf_counter() - start,
                           "rel_error": error, "status": status})
    return points


def plot_work_precision(points: list[dict], path: Path) -> str:
    figure, axis = plt.subplots(figsize=(8, 5))
    for family, colour in zip(dict.fromkeys(p["solver"] for p in points), ("tab:blue", "tab:orange", "tab:green")):
        good = [p for p in points if p["solver"] == family and p["rel_error"] is not None]
        bad = [p for p in points if p["solver"] == family and p["rel_error"] is None]
        axis.plot([p["seconds"] for p in good], [max(p["rel_error"], 1e-16) for p in good], "o-", color=colour,
                  label=family)
        for p in good:
            axis.annotate(p["setting"], (p["seconds"], max(p["rel_error"], 1e-16)), fontsize=6,
                          textcoords="offset points", xytext=(3, 3))
        if bad:
            axis.plot([p["seconds"] for p in bad], [1.0] * len(bad), "x", color=colour, ms=9,
                      label=f"{family}: failed with an FMI error ({', '.join(p['setting'] for p in bad)})")
    default = [p for p in points if p["setting"] == "rtol 1e-07" and p["rel_error"] is not None]
    if default:
        axis.plot([default[0]["seconds"]], [max(default[0]["rel_error"], 1e-16)], "*", ms=16, color="gold",
                  markeredgecolor="k", label="the FMU's default (rtol 1e-7)")
    axis.axhline(1e-6, color="crimson", ls="--", lw=1, label="1e-6 (the accuracy target)")
    axis.set_xscale("log")
    axis.set_yscale("log")
    axis.set_xlabel("seconds per evaluation of the full scene")
    axis.set_ylabel("relative error of the sampled peak (best order)")
    axis.set_title("Speed against accuracy: each solver setting of the FMU against rtol 1e-12", fontsize=9)
    axis.grid(alpha=0.3, which="both")
    axis.legend(fontsize=7)
    return _save(figure, path)


def _fmt(value, digits=2):
    return "n/a" if value is None else f"{value:.{digits}f}"


def render_html(study: Study, accuracy: dict, charts: dict) -> str:
    config = study.config
    data = results_dict(study, accuracy)
    best = data["best"]
    study_order = study.verified.get(STUDY_BEST_ORDER)
    rows = []
    for run in data["runs"]:
        rows.append("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in (
            METHOD_NAMES.get(run["method"], run["method"]), run["seed"], run["evaluations"], run["failed"],
            run["best_order"], _fmt(run["best_peak"]), _fmt(run["best_peak_continuous"]),
            _fmt(run["search_best_peak"]), run["search_best_index"], f"{run['wall_seconds']:.1f} s",
            run["stop_reason"])) + "</tr>")
    local = study.local_check or {}
    local_text = ("not run" if not local else
                  f"The one local search descended from the searches' best {local['start']} by single swaps and "
                  f"insertions ({local['descent_evaluations']} evaluations, {local['moves']} moves) to "
                  f"{local['order']}; all {local['swaps_checked']} swaps and {local['insertions_checked']} "
                  "insertions of that order were evaluated on the search objective. "
                  + ("<b>The best order is locally optimal.</b>" if local.get("locally_optimal")
                     else "<b>The best order is not confirmed locally optimal</b> (see results.json)."))
    disagreements = ("none: on every run the full scene ranks the finalists as the search objective did"
                     if not study.finalist_disagreements else
                     f"{len(study.finalist_disagreements)} run(s) where the full scene reorders the finalists "
                     "(see results.json: finalist_disagreements)")
    accuracy_rows = ""
    best_last_contact = best["last_contact_time"] if best else None
    best_peak_sampled = best["peak_sampled"] if best else None
    if "sampled_relative_error" in accuracy and accuracy.get("sampling_shortfall") is not None:
        accuracy_rows = (
            f"<li>Sampled peak of the best order: {accuracy['sampled_relative_error']:.1e} relative to a "
            f"rtol {accuracy['reference_rtol']:g} reference; continuous peak: "
            f"{accuracy['continuous_relative_error']:.1e}.</li>"
            f"<li>The 0.01 s samples miss {100 * accuracy['sampling_shortfall']:.2f}% of the continuous peak: as large "
            "as the gaps between good orders, which is why both peaks are reported.</li>"
            f"<li>Horizon: the best order's lattice last touches the plate at "
            f"{_fmt(best_last_contact, 3)} s; its sampled peak over "
            + ", ".join(f"{h} s is {_fmt(v, 4)} N" for h, v in accuracy["peak_by_horizon"].items())
            + f" against {_fmt(best_peak_sampled, 4)} N over {study.horizon:g} s.</li>"
            + ("" if accuracy["search_objective_relative_difference"] is None else
               f"<li>The search objective ({data['search_horizon']:g} s horizon, {SEARCH_SOLVER_NAME} at rtol "
               f"{config.search_rtol}) differs "
               f"from the full scene by {accuracy['search_objective_relative_difference']:.1e} for the best order."
               "</li>"))
    study_line = ("" if study_order is None or study_order.status != "ok" else
                  f"<p>The study's best order {list(STUDY_BEST_ORDER)}, evaluated here: "
                  f"{_fmt(study_order.peak)} N ({config.objective}), "
                  f"{_fmt(study_order.details.get('peak_continuous'))} N continuous (published: 1497.89 N).</p>")
    headline = ("<p>No order was evaluated successfully.</p>" if best is None else
                f"<p class='big'>Best order <b>{best['order']}</b>: <b>{_fmt(best['peak'])} N</b> "
                f"({config.objective} peak over {study.horizon:g} s), {_fmt(best['peak_continuous'])} N continuous "
                f"peak at t = {_fmt(best['peak_time'], 4)} s.</p>")
    return f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>Material order study</title>
<style>body{{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}}
table{{border-collapse:collapse;font-size:12px}}td,th{{border:1px solid #ccc;padding:3px 6px}}
.big{{font-size:1.3em}}img{{max-width:100%}}</style></head><body>
<h1>Material order minimising the peak backplate force</h1>
{which_model_html(data)}
{headline}
{cases_html(data)}
{study_line}
<p>Scene {html.escape(config.scene)}, diagonal rule <b>{html.escape(str(data['diagonal_rule']))}</b>,
objective <b>{config.objective}</b>, FMU {html.escape(str(study.fmu_path))}. Searches ran on a
{data['search_horizon']:g} s horizon at rtol {config.search_rtol}; every result below is re-evaluated over the
full {study.horizon:g} s scene at the FMU's default accuracy. Wall time {study.wall_seconds:.1f} s.</p>
{sensitivity_html(data)}
{exhaustive_html(data, charts)}
<h2>How accurate these numbers are</h2><ul>{accuracy_rows}
<li>Finalists: {disagreements}.</li><li>Local optimality: {local_text}</li></ul>
<h2>Convergence</h2><img src="{charts['convergence']}">
<h2>Force over time and energy balance</h2><img src="{charts['force_energy']}">
<h2>The lattices</h2><img src="{charts['lattice']}">
<h2>Speed against accuracy of the FMU's solvers</h2>
<p>The best order over the full scene with every solver setting; the default (DOP853, rtol 1e-7) is what
every number above used. Failures (a diverging fixed-step solver) end in an FMI error, marked x.
The full study over several orders: <code>python bench/work_precision.py --out DIR</code>.</p>
<img src="{charts['work_precision']}">
<h2>Runs</h2>
<table><tr><th>method</th><th>seed</th><th>evaluations</th><th>failed</th><th>best order (full scene)</th>
<th>best peak (N)</th><th>continuous (N)</th><th>search value (N)</th><th>found at</th><th>wall</th>
<th>stopped because</th></tr>
{''.join(rows)}</table>
<p>Data: <a href="results.json">results.json</a>, <a href="evaluations.csv">evaluations.csv</a>,
<a href="journal.jsonl">journal.jsonl</a>. The design for your FMI tool: <a href="best_design.ssp">best_design.ssp</a>
(the FMU with the best order and this run's parameters, as an SSP parameter set).</p>
</body></html>
"""


def which_model_html(data: dict) -> str:
    """The report's opening: both diagonal rules' optima, each judged by both rules, and the energy flows."""
    which = data.get("which_model")
    if not which:
        return ""
    rules = [r for r in ("receiver", "mean") if r in which]
    rows = []
    for rule in rules:
        entry = which[rule]
        cells = [f"optimum under the {rule} rule", entry["order"]]
        for judge in rules:
            energy = entry.get(f"energy_{judge}") or {}
            cells += [_fmt(entry.get(f"peak_{judge}")),
                      f"W_ext {_fmt(energy.get('external_work'), 1)} J, W_nr {_fmt(energy.get('nonreciprocal_work'), 1)}"
                      f" J, D {_fmt(energy.get('dissipated_energy'), 1)} J"]
        rows.append("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in cells) + "</tr>")
    head = "".join(f"<th>peak, {r} rule (N)</th><th>energy flows, {r} rule</th>" for r in rules)
    sentence = ""
    if len(rules) == 2:
        receiver, mean = which["receiver"], which["mean"]
        if receiver["order"] == mean["order"]:
            sentence = "Both rules lead to the same order: the answer does not depend on the model's diagonal rule."
        elif all(receiver.get(f"peak_{r}") == mean.get(f"peak_{r}") for r in ("receiver", "mean")):
            sentence = ("The two orders give the same peaks under both rules (a tie, e.g. a load that never "
                        "reaches the plate): the diagonal rule does not decide between them.")
        else:
            cost = (receiver.get("peak_mean") or 0) - (mean.get("peak_mean") or 0)
            sentence = (f"The two rules lead to different orders. The receiver rule's optimum (the rule the study "
                        f"computed with) gives "
                        f"{_fmt(receiver.get('peak_mean'), 1)} N in the physically reciprocal (mean) model, {_fmt(cost, 1)} N "
                        f"more than that model's own optimum. The receiver rule breaks Newton's third law on the "
                        f"diagonals between different materials and its non-reciprocal work (W_nr, negative) takes "
                        f"energy out of the lattice; its optimum exploits that sink. A designer who builds real armour "
                        f"should trust the mean rule's order unless the receiver rule is known to describe the "
                        f"material, and should check the chosen order under both.")
    return (f"<h2>Which model, which optimum</h2><table><tr><th></th><th>order</th>{head}</tr>{''.join(rows)}"
            f"</table><p>{html.escape(sentence)} (Full scene at the FMU's default accuracy; "
            f"W_ext external work, W_nr non-reciprocal work, D dissipated energy.)</p>")


def cases_html(data: dict) -> str:
    best = data.get("best") or {}
    if not best.get("cases"):
        return ""
    rows = "".join(f"<tr><td>{html.escape(str(c['parameters']))}</td><td>{_fmt(c['peak'])}</td></tr>"
                   for c in best["cases"])
    return (f"<p>Load cases: the value above is the <b>{html.escape(str(best.get('aggregate')))}</b> over "
            f"{len(best['cases'])} cases.</p><table><tr><th>case</th><th>peak (N)</th></tr>{rows}</table>")


def sensitivity_html(data: dict) -> str:
    sensitivity = data.get("sensitivity")
    if not sensitivity:
        return ""
    labels = list(dict.fromkeys(label for v in sensitivity["variations"] for label in v["orders"]))
    head = "".join(f"<th>{html.escape(label)}: peak (regret) N</th>" for label in labels)
    rows = []
    for variation in sensitivity["variations"]:
        found = variation["best_found"] or {}
        cells = [f"<td>{html.escape(variation['variation'])}</td>",
                 f"<td>{html.escape(str(found.get('order')))} {_fmt(found.get('peak'))}</td>"]
        for label in labels:
            entry = variation["orders"].get(label, {})
            cells.append(f"<td>{_fmt(entry.get('peak'))} ({_fmt(entry.get('regret'))})</td>")
        rows.append("<tr>" + "".join(cells) + "</tr>")
    return (f"<h2>How the chosen order holds up when the case changes</h2><p>Each variation of the scene: the "
            f"chosen order, the sequential one and the study's, against the best order short searches "
            f"(annealing from the sequential order and an iterated local search from the chosen order, "
            f"{sensitivity['budget']} evaluations each) find for that variation. "
            f"The regret is what keeping the order costs there (full scene).</p>"
            f"<table><tr><th>variation</th><th>best found for it</th>{head}</tr>{''.join(rows)}</table>")


def plot_exhaustive(study: Study, path: Path) -> str:
    """The distribution of every order's peak (search fidelity), the optimum, the best orders and each
    search run's best marked."""
    result = study.exhaustive
    histogram = result["histogram"]
    resolution = float(histogram["resolution"])
    bins = sorted((int(k), v) for k, v in histogram["counts"].items())
    figure, axis = plt.subplots(figsize=(9, 4.5))
    if bins:
        lefts = np.array([(1 + resolution) ** k for k, _ in bins])
        exact = sum(v for _, v in bins)
        stopped = result.get("censored", 0)
        axis.bar(lefts, [v for _, v in bins], width=lefts * resolution, align="edge", color="tab:gray",
                 label=f"{exact:,} of {result['orders']:,} orders" + (
                     f"; the other {stopped:,} passed the incumbent's force limit and were stopped there "
                     "(their peaks are above it, not computed)" if stopped else ""))
    optimum = result.get("optimum")
    if optimum:
        axis.axvline(optimum["peak"], color="crimson", lw=2, label=f"optimum {optimum['order']}: {optimum['peak']:.3f} N")
    for entry in result.get("top", [])[1:6]:
        axis.axvline(entry["peak"], color="crimson", lw=0.6, ls=":")
    for run in study.runs:
        if run.best_peak is not None:
            axis.axvline(run.best_peak, color=COLOURS.get(run.method, "tab:blue"), lw=1, ls="--")
    axis.plot([], [], color="tab:blue", ls="--", label="each search run's best (search fidelity)")
    axis.set_yscale("log")
    axis.set_xlabel("peak backplate force (N), search fidelity")
    axis.set_ylabel("orders")
    axis.set_title("Every order's peak: the exhaustive sweep", fontsize=9)
    axis.legend(fontsize=7)
    axis.grid(alpha=0.3)
    return _save(figure, path)


def exhaustive_html(data: dict, charts: dict) -> str:
    result = data.get("exhaustive")
    if not result:
        return ""
    optimum = result.get("optimum") or {}
    tolerance = optimum.get("tolerance")
    return (f"<h2>Exhaustive search: the known optimum</h2><p>Every one of the {result['orders']:,} orders was "
            f"screened at the search fidelity ({result['chunks']} chunks, {result['from_checkpoint']} from the "
            f"checkpoint, {_fmt(result.get('orders_per_core_second'), 0)} orders per core-second); the "
            f"{result.get('full_fidelity_checks')} orders within {result['screening_error']:g} (relative) of the "
            f"best were evaluated over the full scene. The optimum is <b>{optimum.get('order')}</b> at "
            f"<b>{_fmt(optimum.get('peak'), 4)} N</b>"
            + (f" (to {tolerance:.1e} N)" if tolerance is not None else "")
            + f"; the runner-up is at {_fmt(optimum.get('runner_up_peak'), 4)} N.</p>"
            + (f"<img src=\"{charts['exhaustive']}\">" if "exhaustive" in charts else ""))
