"""The exhaustive sweep: every design of the space under each diagonal rule, verified, with a certificate."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..charts import plt, save
from ..exhaustive import (
    HISTOGRAM_RESOLUTION,
    MAX_LOCAL_DESIGNS,
    SWEEP_METHOD,
    ChunkResult,
    Scored,
    ScreenChunk,
    calibration_range,
    chunk_ranges,
    coverage,
    not_strongly_dominated,
    projected_cost,
    screening_threshold,
)
from ..known_optima import known_optimum
from ..loop import run_search
from ..objective import FULL, SEARCH
from ..options import check_options, integer, option
from ..search import make_search
from ..search.pareto import non_dominated
from ..study import SILENT, Step, StudyContext, Verdict
from ..types import Evaluation, Order, RunOutputs
from .searches import Searches, default_evaluations, rule_label

# The screening fidelity's relative error bound, at least ten times what python -m bench.work_precision and
# python -m bench.horizon_study measure for the searches' fidelity; every design within it of the best is verified.
SCREENING_ERROR = 1e-4
# The full fidelity's own error bound (python -m bench.work_precision measures the FMU's default accuracy).
FULL_ERROR = 1e-6
# How many designs a sweep (alone, its chunks lowering their force limit as they go) screens in the core-time of
# one evaluation of the default searches, rounded down: `python -m bench.sweep_crossover` measures it and writes
# docs/measurements/sweep_crossover.md. The default study sweeps a space of at most this many designs per
# evaluation its searches would make, instead of searching it.
SWEEP_DESIGNS_PER_SEARCH_EVALUATION = 3
SECOND_INTEGRATOR = {"solver": "rkn5", "rtol": 1e-10, "atol": 1e-12}
SECOND_INTEGRATOR_NAME = "Fine's Runge-Kutta-Nystrom 5(4) pair at rtol 1e-10"
BEST_PER_CHUNK = 20
VERIFY_TOP = 5
SWEEP_CHUNKS = 200  # chunks of a sweep without --chunk-size
INCUMBENT_BUDGET = 100  # designs of the short annealing run that gives a projection its incumbent


@dataclass(frozen=True)
class ExhaustiveConfig:
    chunk_size: int | None = option(
        None,
        "designs per chunk of the exhaustive sweep (a chunk is one task: journalled, resumed, retried)",
        type=integer("--chunk-size", 1, 10**9),
        show_default=f"about {SWEEP_CHUNKS} chunks",
    )

    def __post_init__(self):
        check_options(self)


@dataclass(frozen=True)
class SweepCost:
    """What a sweep of the space would cost, projected from one chunk timed as the sweep runs its chunks: the
    force limit at the screening threshold of the best value known before it (so most designs are censored)."""

    designs: int  # of the space
    designs_per_core_second: float
    core_hours: float
    incumbent: float | None  # the best value known (search fidelity) whose threshold is the chunk's limit
    timed: int  # designs of the timed chunk
    censored: int  # of them, stopped above the limit


def asked(context: StudyContext) -> bool:
    """Whether the user asked for the sweep: its method name among --method's."""
    return SWEEP_METHOD in context.config(Searches).methods


def missing_for_sweep(context: StudyContext) -> str:
    """What a sweep beyond the local limit still needs: a Dask cluster, the confirmation of its cost, or both."""
    if context.executor_kind == "dask":
        return "confirm its cost with --confirm-cost"
    if context.confirm_cost:
        return "run it on a Dask cluster: --executor dask --scheduler ADDRESS (confirmed already)"
    return "run it on a Dask cluster, confirmed: --executor dask --scheduler ADDRESS --confirm-cost"


def sweep_instead(context: StudyContext) -> bool:
    """Whether the default study sweeps the space instead of searching it: no --method given, one objective and
    one load case, and a space small enough that the sweep costs less than the default searches would (then it
    also certifies its answer)."""
    config = context.config(Searches)
    if config.methods or len(context.case.outputs) > 1 or len(context.case.cases) > 1:
        return False
    return context.case.space.size <= SWEEP_DESIGNS_PER_SEARCH_EVALUATION * default_evaluations(config)


def objective_covered(context: StudyContext, label: str) -> str:
    """The objective a certificate holds for, in words: one of the sampled peak says nothing of the continuous
    one, nor of another horizon or rule."""
    output = context.case.outputs[0]
    if output == "peak_backplate_force":
        interval = context.case.parameters.get("peak_sample_interval", context.fmu.start("peak_sample_interval"))
        what = f"the sampled peak ({interval:g} s samples)" if interval is not None else "the sampled peak"
    else:
        what = {"peak_backplate_force_continuous": "the continuous peak"}.get(output, output)
    return f"{what} over {context.case.horizon:g} s under the {label} rule"


def sweep_cost(context: StudyContext, rule: str | None, incumbent: float | None) -> SweepCost:
    """The projected cost of sweeping the space under ``rule``, with the force limit at ``incumbent``'s
    threshold (a chunk from the middle of the ranks, through the one Evaluator: journalled, resumed)."""
    objective = context.objective(rule)
    space = context.case.space
    (screening,) = objective.tasks(SEARCH)
    limit = (
        screening_threshold(incumbent, SCREENING_ERROR)
        if incumbent is not None and math.isfinite(incumbent) and objective.supports_limits
        else None
    )
    start, stop = calibration_range(space)
    (chunk,) = context.evaluator.run(
        [ScreenChunk(screening, space, start, stop, BEST_PER_CHUNK, SCREENING_ERROR, limit)]
    )
    rate, hours = projected_cost(chunk, space)
    return SweepCost(space.size, rate, hours, incumbent if limit is not None else None, chunk.designs, chunk.censored)


def projection_incumbent(context: StudyContext, rule: str | None) -> float | None:
    """The best value a sweep would start from, found before the run: the case's known optimum at the search
    fidelity, else the best of a short annealing run (a sweep after the searches starts lower, so the
    projection errs on the costly side)."""
    objective = context.objective(rule)
    known = known_optimum(context.case, rule or context.case.rule_default)
    if known is not None:
        value = objective.evaluate([known.order], context.evaluator, SEARCH)[0]
        if value.ok:
            return value.value
    search = make_search("sa", context.case.space, context.config(Searches).seed, budget=INCUMBENT_BUDGET)
    run = run_search(
        search,
        objective,
        INCUMBENT_BUDGET,
        context.evaluator,
        method_name="sa",
        seed=context.config(Searches).seed,
        label=rule_label(rule),
    )
    return run.best_value


@dataclass(frozen=True)
class Verified:
    """A design checked at full fidelity (and, for the optimum and the runner-up, by a second integrator)."""

    order: Order
    full: float | None
    screened: float | None
    second: float | None = None
    status: str = "ok"
    message: str = ""


@dataclass(frozen=True)
class Certificate:
    """The evidence that the sweep's optimum is the optimum (``certified`` only when all of it holds)."""

    diagonal_rule: str
    space: str
    designs: int
    chunks: int
    ranks: str
    covered_once: bool
    screened: int
    censored: int
    failed: int
    verified: int
    screening_error: float
    max_screening_error_seen: float | None
    screening_bound_held: bool
    second_integrator: str
    optimum: Verified | None
    runner_up: Verified | None
    gap: float | None
    integration_error: float | None
    certified: bool
    reasons: tuple[str, ...]  # why not certified (empty when certified)
    objective: str = ""  # what the certificate covers: the objective, its horizon and the diagonal rule


@dataclass(frozen=True)
class Sweep:
    diagonal_rule: str
    certificate: Certificate
    chunk_size: int
    chunks_resumed: int
    initial_limit: float | None
    top: tuple[Scored, ...]
    histogram: tuple[tuple[int, int], ...]
    histogram_resolution: float
    verified: tuple[Evaluation, ...]
    cpu_seconds: float
    designs_per_core_second: float | None


@dataclass(frozen=True)
class FrontPoint:
    """A design on a Pareto front and its objective values at full fidelity."""

    order: Order
    values: tuple[float, ...]
    outputs: RunOutputs | None = None


@dataclass(frozen=True)
class FrontSweep:
    """A sweep with several objectives: the exact Pareto front of the space."""

    diagonal_rule: str
    space: str
    designs: int
    chunks: int
    ranks: str
    covered_once: bool
    failed: int
    candidates: int  # designs no other beats on every objective by more than the screening error
    screening_error: float
    max_screening_error_seen: float | None
    front: tuple[FrontPoint, ...]
    exact: bool
    reasons: tuple[str, ...]


@dataclass(frozen=True)
class ExhaustiveResult:
    sweeps: tuple[Sweep, ...]
    fronts: tuple[FrontSweep, ...] = ()
    why: str = ""  # why this run swept: asked, or the default study of a space cheaper to sweep than to search

    def for_rule(self, label: str) -> Sweep | None:
        return next((s for s in self.sweeps if s.diagonal_rule == label), None)

    def front_for_rule(self, label: str) -> FrontSweep | None:
        return next((f for f in self.fronts if f.diagonal_rule == label), None)


class Exhaustive(Step):
    name = "exhaustive"
    title = "Exhaustive sweep"
    template = "exhaustive.html.j2"
    chart_file = "exhaustive.png"
    Config = ExhaustiveConfig

    def applies(self, context: StudyContext) -> bool:
        """Asked (--method exhaustive), or the default study of a space cheaper to sweep than to search."""
        return asked(context) or sweep_instead(context)

    def replaces(self, context: StudyContext) -> tuple[type, ...]:
        """The default study of a small space sweeps it instead of searching it."""
        return (Searches,) if sweep_instead(context) else ()

    def check(self, context: StudyContext) -> None:
        if not self.applies(context):
            if "chunk_size" in context.given(Exhaustive):
                raise ValueError(f"--chunk-size: only with --method {SWEEP_METHOD}")
            return
        if len(context.case.cases) > 1:
            raise ValueError(f"--method {SWEEP_METHOD}: one load case only (without --case)")
        space = context.case.space
        if space.size > MAX_LOCAL_DESIGNS:
            context.beyond_bounds.append("exhaustive")
        if space.size > MAX_LOCAL_DESIGNS and not (context.executor_kind == "dask" and context.confirm_cost):
            rule = context.rules[0]
            cost = sweep_cost(context, rule, projection_incumbent(context, rule))
            count = len(context.rules)
            per_rule = f" ({cost.core_hours:,.1f} per rule, {count} rules)" if count > 1 else ""
            raise ValueError(
                f"--method {SWEEP_METHOD}: {space.size:,} designs is beyond the local limit of {MAX_LOCAL_DESIGNS:,}: "
                f"projected {cost.core_hours * count:,.1f} core-hours{per_rule} at "
                f"{cost.designs_per_core_second:,.0f} designs per core-second (measured here on {cost.timed} designs, "
                f"{cost.censored} stopped at the force limit as the sweep's chunks are); {missing_for_sweep(context)}"
            )

    def run(self, context: StudyContext) -> ExhaustiveResult:
        why = f"asked (--method {SWEEP_METHOD})"
        if sweep_instead(context):
            evaluations = default_evaluations(context.config(Searches))
            why = (
                f"the default study sweeps a space of at most {SWEEP_DESIGNS_PER_SEARCH_EVALUATION} designs per "
                f"evaluation its searches would make ({evaluations:,} per rule at this budget): "
                f"{context.case.space.size:,} designs cost less to sweep than to search, and the sweep certifies"
            )
        if len(context.case.outputs) > 1:
            return ExhaustiveResult((), tuple(self.sweep_front(context, rule) for rule in context.rules), why)
        return ExhaustiveResult(tuple(self.sweep(context, rule) for rule in context.rules), why=why)

    def chunks(self, context: StudyContext, label: str, tasks, count: int) -> list[ChunkResult]:
        with context.progress.bar(count, f"exhaustive sweep ({label})", unit="chunk") as bar:
            return context.evaluator.run(tasks, progress=bar)

    def sweep_front(self, context: StudyContext, rule: str | None) -> FrontSweep:
        """Every design with several objectives: the candidates of the chunks merged, verified at full
        fidelity, the non-dominated ones the exact front."""
        label = rule_label(rule)
        objective = context.objective(rule)
        space = context.case.space
        (screening,) = objective.tasks(SEARCH)
        chunk_size = self.config.chunk_size or max(1, -(-space.size // SWEEP_CHUNKS))
        ranges = chunk_ranges(space.size, chunk_size)
        tasks = (
            ScreenChunk(
                screening, space, a, b, BEST_PER_CHUNK, SCREENING_ERROR, None, objectives=len(context.case.outputs)
            )
            for a, b in ranges
        )
        chunks = self.chunks(context, label, tasks, len(ranges))
        good = [c for c in chunks if c.ok]
        within = [s for c in good for s in c.within]
        mask = not_strongly_dominated([s.values for s in within], SCREENING_ERROR)
        candidates = [s for s, k in zip(within, mask) if k]
        failures = [f.order for c in good for f in c.failures]
        orders = list(dict.fromkeys([s.order for s in candidates] + failures))
        full = objective.evaluate(orders, context.evaluator, FULL)
        ok = [e for e in full if e.ok]
        screened = {s.order: s.values for s in candidates}
        errors = [abs(a / b - 1) for e in ok if e.order in screened for a, b in zip(screened[e.order], e.values) if b]
        front_mask = non_dominated([e.values for e in ok]) if ok else np.zeros(0, dtype=bool)
        front = tuple(
            sorted(
                (FrontPoint(e.order, e.values, e.outputs) for e, k in zip(ok, front_mask) if k), key=lambda p: p.values
            )
        )
        covered, ranks = coverage(good, space.size)
        reasons = []
        if not covered:
            reasons.append(f"the chunks do not cover the space exactly once ({ranks})")
        if len(good) < len(chunks):
            reasons.append(f"{len(chunks) - len(good)} chunk(s) failed")
        unverified = [e for e in full if not e.ok and e.order in failures]
        if unverified:
            reasons.append(f"{len(unverified)} design(s) failed at screening and at full fidelity")
        largest = max(errors) if errors else None
        if largest is None or largest > SCREENING_ERROR:
            reasons.append("the screening error bound did not hold" if largest is not None else "nothing verified")
        return FrontSweep(
            label,
            space.describe(),
            space.size,
            len(ranges),
            ranks,
            covered,
            sum(c.failed for c in good),
            len(candidates),
            SCREENING_ERROR,
            largest,
            front,
            not reasons,
            tuple(reasons),
        )

    def sweep(self, context: StudyContext, rule: str | None) -> Sweep:
        label = rule_label(rule)
        objective = context.objective(rule)
        space = context.case.space
        (screening,) = objective.tasks(SEARCH)
        searched = context.result(Searches)
        known = [e.value for run in (searched.runs_for(label) if searched else []) for e in run.evaluations if e.ok]
        best = [min(known) if known else math.inf]
        chunk_size = self.config.chunk_size or max(1, -(-space.size // SWEEP_CHUNKS))
        ranges = chunk_ranges(space.size, chunk_size)
        limits = objective.supports_limits
        initial_limit = screening_threshold(best[0], SCREENING_ERROR) if limits and math.isfinite(best[0]) else None
        resumed_before = context.evaluator.cache_hits

        def tasks():
            for start, stop in ranges:
                limit = screening_threshold(best[0], SCREENING_ERROR) if limits and math.isfinite(best[0]) else None
                yield ScreenChunk(screening, space, start, stop, BEST_PER_CHUNK, SCREENING_ERROR, limit)

        def on_result(index: int, chunk: ChunkResult) -> None:
            if chunk.ok and chunk.best:
                best[0] = min(best[0], chunk.best[0].value)

        with context.progress.bar(len(ranges), f"exhaustive sweep ({label})", unit="chunk") as bar:
            chunks: list[ChunkResult] = context.evaluator.run(tasks(), progress=bar, on_result=on_result)
        resumed = context.evaluator.cache_hits - resumed_before
        good = [c for c in chunks if c.ok]
        scored = sorted((s for c in good for s in c.best), key=lambda s: s.value)
        screened_best = scored[0].value if scored else None
        threshold = screening_threshold(screened_best, SCREENING_ERROR) if screened_best is not None else None
        candidates = sorted(
            (s for c in good for s in c.within if threshold is not None and s.value <= threshold), key=lambda s: s.value
        )
        failures = [f.order for c in good for f in c.failures]
        orders = list(dict.fromkeys([s.order for s in candidates] + failures + [s.order for s in scored[:VERIFY_TOP]]))
        full = dict(zip(orders, objective.evaluate(orders, context.evaluator, FULL)))
        screened = {s.order: s.value for s in scored + candidates}
        ok = sorted((e for e in full.values() if e.ok), key=lambda e: e.ok_value)
        errors = [abs(screened[e.order] / e.value - 1) for e in ok if e.order in screened and e.value]
        second = self.second_integrator(context, objective, [e.order for e in ok[:2]])
        certificate = self.certify(
            label,
            space,
            chunks,
            ranges,
            screened,
            ok,
            errors,
            second,
            len(orders),
            [c for c in chunks if not c.ok],
            failures,
            full,
        )
        certificate = replace(certificate, objective=objective_covered(context, label))
        histogram: dict[int, int] = {}
        for chunk in good:
            for index, count in chunk.histogram:
                histogram[index] = histogram.get(index, 0) + count
        cpu = sum(c.cpu_seconds for c in good)
        return Sweep(
            label,
            certificate,
            chunk_size,
            resumed,
            initial_limit,
            tuple(scored[:BEST_PER_CHUNK]),
            tuple(sorted(histogram.items())),
            HISTOGRAM_RESOLUTION,
            tuple(full.values()),
            cpu,
            sum(c.designs for c in good) / cpu if cpu > 0 else None,
        )

    @staticmethod
    def second_integrator(context: StudyContext, objective, orders: list[Order]) -> dict[Order, Evaluation]:
        (full,) = objective.tasks(FULL)
        second = full.with_parameters(**SECOND_INTEGRATOR)
        return dict(zip(orders, context.evaluator.evaluate([(second, o) for o in orders])))

    @staticmethod
    def certify(
        label, space, chunks, ranges, screened, ok, errors, second, verified_count, failed_chunks, failures, full
    ) -> Certificate:
        reasons = []
        covered, ranks = coverage([c for c in chunks if c.ok], space.size)
        if not covered:
            reasons.append(f"the chunks do not cover the space exactly once ({ranks})")
        if failed_chunks:
            reasons.append(f"{len(failed_chunks)} chunk(s) failed: {failed_chunks[0].message}")
        unverified = [o for o in failures if not full[o].ok]
        if unverified:
            reasons.append(
                f"{len(unverified)} design(s) failed at screening and at full fidelity "
                f"(first: {list(unverified[0])}: {full[unverified[0]].message})"
            )
        largest = max(errors) if errors else None
        held = largest is not None and largest <= SCREENING_ERROR
        if not held:
            reasons.append(
                "the screening error bound did not hold"
                if largest is not None
                else "no design was verified at full fidelity"
            )

        def verified(e: Evaluation) -> Verified:
            other = second.get(e.order)
            return Verified(e.order, e.ok_value, screened.get(e.order), other.value if other and other.ok else None)

        optimum = verified(ok[0]) if ok else None
        runner_up = verified(ok[1]) if len(ok) > 1 else None
        gap = integration = None
        if optimum and runner_up:
            optimum_full, runner_up_full = ok[0].ok_value, ok[1].ok_value
            gap = runner_up_full - optimum_full
            if optimum.second is None or runner_up.second is None:
                reasons.append("the second integrator failed on the optimum or the runner-up")
            else:
                integration = max(abs(optimum_full - optimum.second), abs(runner_up_full - runner_up.second))
                if not gap > 2 * integration:
                    reasons.append(
                        f"the gap to the runner-up ({gap:.3g}) is not larger than twice the integration "
                        f"error ({integration:.3g})"
                    )
        elif optimum is None:
            reasons.append("no design has a value")
        good = [c for c in chunks if c.ok]
        return Certificate(
            diagonal_rule=label,
            space=space.describe(),
            designs=space.size,
            chunks=len(ranges),
            ranks=ranks,
            covered_once=covered,
            screened=sum(c.designs - c.failed - c.censored for c in good),
            censored=sum(c.censored for c in good),
            failed=sum(c.failed for c in good),
            verified=verified_count,
            screening_error=SCREENING_ERROR,
            max_screening_error_seen=largest,
            screening_bound_held=held,
            second_integrator=SECOND_INTEGRATOR_NAME,
            optimum=optimum,
            runner_up=runner_up,
            gap=gap,
            integration_error=integration,
            certified=not reasons,
            reasons=tuple(reasons),
        )

    def verdict(self, result: ExhaustiveResult | None, study) -> Verdict:
        """No answer when the screening error passed its bound: designs the sweep pruned may be better."""
        for sweep in result.sweeps if result else ():
            certificate = sweep.certificate
            if certificate.max_screening_error_seen is not None and not certificate.screening_bound_held:
                return Verdict.no_answer(
                    f"the exhaustive sweep's screening error ({certificate.max_screening_error_seen:.2g}) passed its "
                    f"bound ({certificate.screening_error:g}) under the {sweep.diagonal_rule} rule: designs it pruned "
                    "may be better than its optimum, which is not certain"
                )
        for front in result.fronts if result else ():
            if front.max_screening_error_seen is not None and front.max_screening_error_seen > front.screening_error:
                return Verdict.no_answer(
                    f"the exhaustive sweep's screening error ({front.max_screening_error_seen:.2g}) passed its bound "
                    f"({front.screening_error:g}) under the {front.diagonal_rule} rule: its front may miss designs"
                )
        return SILENT

    def cost_note(self, context: StudyContext) -> str:
        return (
            "every design of the space, in chunks (a chunk is one task), then its candidates at full fidelity: "
            "a sweep is not bounded by --budget"
        )

    def chart(self, study, path):
        return draw_exhaustive(study, path)


def draw_exhaustive(study, path: Path) -> str | None:
    result = study.result(Exhaustive)
    if result is None or not result.sweeps:  # a sweep with several objectives draws its front (the Pareto step)
        return None
    figure, axes = plt.subplots(1, len(result.sweeps), figsize=(7 * len(result.sweeps), 4.5), squeeze=False)
    unit = study.case.objective.units[0]
    for axis, sweep in zip(axes[0], result.sweeps):
        bins = sweep.histogram
        certificate = sweep.certificate
        if bins:
            lefts = np.array([(1 + sweep.histogram_resolution) ** k for k, _ in bins])
            axis.bar(
                lefts,
                [v for _, v in bins],
                width=lefts * sweep.histogram_resolution,
                align="edge",
                color="tab:gray",
                label=f"{certificate.screened:,} designs screened to a value"
                + (
                    f"; {certificate.censored:,} more stopped above the force limit (censored)"
                    if certificate.censored
                    else ""
                ),
            )
        if certificate.optimum:
            axis.axvline(
                certificate.optimum.full,
                color="crimson",
                lw=2,
                label=f"optimum {list(certificate.optimum.order)}: {certificate.optimum.full:.4f} {unit}",
            )
        if bins:
            axis.set_yscale("log")
        axis.set_xlabel(f"{study.case.objective.outputs[0]} ({unit}), screening fidelity")
        axis.set_ylabel("designs")
        axis.set_title(f"Every design's value, {sweep.diagonal_rule} rule", fontsize=9)
        if axis.get_legend_handles_labels()[0]:
            axis.legend(fontsize=7)
        axis.grid(alpha=0.3)
    return save(figure, path)


__all__ = [
    "Certificate",
    "Exhaustive",
    "ExhaustiveConfig",
    "ExhaustiveResult",
    "FULL_ERROR",
    "FrontPoint",
    "FrontSweep",
    "SCREENING_ERROR",
    "SWEEP_DESIGNS_PER_SEARCH_EVALUATION",
    "Sweep",
    "SweepCost",
    "Verified",
    "asked",
    "objective_covered",
    "projection_incumbent",
    "sweep_cost",
    "sweep_instead",
]
