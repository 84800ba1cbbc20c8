"""The force on the backplate over time for the answers and the baselines, and the energy balance of each
answer: the report's charts, computed as tasks of the evaluator (journalled, resumed, parallel)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..charts import COLOURS, RULE_COLOURS, figure_title, legend_below, plt, save
from ..objective import FULL, RecordRun, Trajectory
from ..simulation import ENERGY_OUTPUTS
from ..study import PROJECTILE, Step, StudyContext
from .answers import Answers
from .finalists import baselines

FORCE_HORIZON = 1.0  # s: the pulse's force peaks and ends well before (python -m bench.horizon_study)
IMPACT_CHART = "impact.png"  # under a projectile, the first screen's: contact force beside backplate force
FORCE_STEP = 1e-3
ENERGY_STEP = 1e-2


@dataclass(frozen=True)
class LabelledTrajectory:
    label: str
    diagonal_rule: str
    trajectory: Trajectory


@dataclass(frozen=True)
class TrajectoriesResult:
    force: tuple[LabelledTrajectory, ...]  # backplate_force (and contact_force under a projectile), chosen rule
    energy: tuple[LabelledTrajectory, ...]  # each answer's energy terms under its own rule


def record(context: StudyContext, rule_label: str, order, horizon: float, step: float, outputs) -> RecordRun:
    rule = rule_label if rule_label in context.case.rules else None
    (full,) = context.objective(rule).with_cases(None).tasks(FULL)
    return RecordRun(full.fmu_path, order, horizon, step, full.parameters, tuple(outputs), full.fmu_sha256)


class Trajectories(Step):
    name = "trajectories"
    title = "Force over time and energy balance"
    template = "trajectories.html.j2"
    chart_file = "force_energy.png"

    def applies(self, context: StudyContext) -> bool:
        answers = context.result(Answers)
        return answers is not None and answers.chosen is not None

    def run(self, context: StudyContext) -> TrajectoriesResult:
        answers = context.result(Answers).answers
        chosen = answers[0]
        designs = {f"{a.diagonal_rule} rule's answer": a.order for a in answers}
        for label, order in baselines(context).items():
            designs.setdefault(label, order)
        case = context.case
        horizon = min(max(FORCE_HORIZON, case.search_horizon or case.horizon), case.horizon)  # the searches' span
        forces = ("backplate_force", "contact_force") if case.load_mode == PROJECTILE else ("backplate_force",)
        force_tasks = [
            record(context, chosen.diagonal_rule, order, horizon, FORCE_STEP, forces) for order in designs.values()
        ]
        energy_tasks = [
            record(context, a.diagonal_rule, a.order, context.case.horizon, ENERGY_STEP, ENERGY_OUTPUTS)
            for a in answers
        ]
        results = context.evaluator.run(force_tasks + energy_tasks)
        force = tuple(
            LabelledTrajectory(label, chosen.diagonal_rule, t) for label, t in zip(designs, results[: len(force_tasks)])
        )
        energy = tuple(
            LabelledTrajectory(f"{a.diagonal_rule} rule's answer", a.diagonal_rule, t)
            for a, t in zip(answers, results[len(force_tasks) :])
        )
        return TrajectoriesResult(force, energy)

    def cost_note(self, context: StudyContext) -> str:
        return "one recorded run of each answer and baseline for the force and energy charts, whatever the budget"

    def chart(self, study, path):
        return draw_force_and_energy(
            study, path, study.case.line(), struck=study.case.load.get("load_mode") == PROJECTILE
        )


def draw_impact(study, path: Path) -> str | None:
    """Under a projectile, the first screen's chart: the contact force on the face beside the force on the
    backplate, over time, for each answer and baseline (what goes in against what comes through)."""
    trajectories = study.result(Trajectories)
    load = study.case.load
    if trajectories is None or load.get("load_mode") != PROJECTILE:
        return None
    drawn = [t for t in trajectories.force if t.trajectory.ok and "contact_force" in t.trajectory.values]
    if not drawn:
        return None
    figure, (contact_axis, plate_axis) = plt.subplots(1, 2, figsize=(13, 4.4), sharex=True)
    colours = ["tab:blue", "tab:red", "black", "tab:gray", "tab:green"]
    for labelled, colour in zip(drawn, colours):
        t = labelled.trajectory
        contact = np.array(t.values["contact_force"])
        plate = np.array(t.values["backplate_force"])
        contact_axis.plot(
            t.time, contact, color=colour, label=f"{labelled.label} {list(t.order)}: peak {contact.max():.1f} N"
        )
        plate_axis.plot(
            t.time, plate, color=colour, label=f"{labelled.label} {list(t.order)}: peak {plate.max():.1f} N every 1 ms"
        )
    contact_axis.set_title(
        f"Contact force of the {load['projectile_mass']:g} kg projectile at "
        f"{load['projectile_speed']:g} m/s on column 1",
        fontsize=9,
    )
    plate_axis.set_title(f"Force on the backplate ({drawn[0].diagonal_rule} rule)", fontsize=9)
    for axis, what in ((contact_axis, "contact force (N)"), (plate_axis, "backplate force (N)")):
        axis.set_xlabel("time (s)")
        axis.set_ylabel(what)
        axis.grid(alpha=0.3)
        legend_below(axis, fontsize=6.5)
    figure_title(figure, study.case.line())
    return save(figure, path)


def draw_force_and_energy(study, path: Path, context_line: str, struck: bool = False) -> str | None:
    """``struck``: the load is a projectile, whose kinetic energy at the start (E_0) is what the balance holds in
    place of external work."""
    trajectories = study.result(Trajectories)
    if trajectories is None:
        return None
    figure, (force_axis, energy_axis) = plt.subplots(1, 2, figsize=(13, 5.6))
    # the answers in their rules' colours, the sequential baseline in the baseline method's, the others grey
    # and dashed; the chosen design (the first) is drawn last, so no other curve hides it
    colours = {
        labelled.label: colour
        for labelled, colour in zip([f for f in trajectories.force if f.label.endswith("rule's answer")], RULE_COLOURS)
    }
    colours["sequential"] = COLOURS["sequential"]
    for rank, labelled in reversed(list(enumerate(trajectories.force))):
        t = labelled.trajectory
        if not t.ok:
            continue
        force = np.array(t.values["backplate_force"])
        time = np.array(t.time)
        samples = np.abs(time / 0.01 - np.round(time / 0.01)) < 1e-6
        sampled = force[samples].max() if samples.any() else float("nan")
        answer = labelled.label in colours and labelled.label != "sequential"
        force_axis.plot(
            time,
            force,
            color=colours.get(labelled.label, "0.55"),
            lw=2.2 if rank == 0 else 1.3,
            ls="-" if answer else (0, (5, 2)),
            zorder=3 if rank == 0 else 2,
            label=f"{labelled.label} {list(t.order)}: peak {force.max():.1f} N every 1 ms, "
            f"{sampled:.1f} N at the 0.01 s samples",
        )
    handles, labels = force_axis.get_legend_handles_labels()
    force_axis.legend(
        handles[::-1], labels[::-1], fontsize=7.5, loc="upper center", bbox_to_anchor=(0.5, -0.16), frameon=False
    )  # in the order of the designs: the chosen one first
    force_axis.set_xlabel("time (s)")
    force_axis.set_ylabel("backplate force (N)")
    force_axis.set_title(
        f"Force on the backplate ({trajectories.force[0].diagonal_rule if trajectories.force else ''}"
        f" rule), recorded every 1 ms",
        fontsize=9,
    )
    force_axis.grid(alpha=0.3)
    names = {
        "kinetic_energy": "KE",
        "potential_energy": "PE",
        "external_work": "W_ext",
        "dissipated_energy": "D",
        "nonreciprocal_work": "W_nr",
        "energy_balance_error": "balance error",
    }
    if trajectories.energy and trajectories.energy[0].trajectory.ok:
        first = trajectories.energy[0]
        for name, values in first.trajectory.values.items():
            energy_axis.plot(
                first.trajectory.time,
                values,
                ":" if name == "energy_balance_error" else "-",
                label=names.get(name, name),
            )
        balance = "E_0 + W_nr = KE + PE + D" if struck else "W_ext + W_nr = KE + PE + D"
        energy_axis.set_title(f"Energy of the {first.label} ({first.diagonal_rule} rule): {balance}", fontsize=9)
        legend_below(energy_axis, columns=3)
    energy_axis.set_xlabel("time (s)")
    energy_axis.set_ylabel("energy (J)")
    energy_axis.grid(alpha=0.3)
    figure_title(figure, context_line)
    return save(figure, path)


__all__ = ["IMPACT_CHART", "LabelledTrajectory", "Trajectories", "TrajectoriesResult", "draw_impact"]
