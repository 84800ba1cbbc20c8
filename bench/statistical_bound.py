"""The statistical bound validated where the optimum is known, then quoted where it is not.

    python -m bench.statistical_bound            # 11 x 8 and 11 x 7 x 11 swept, 11! sampled; quotes for 12 columns
                                                 # and the 11 x 11 x 11 plate
    python -m bench.statistical_bound --quick    # 11 x 6 and 11 x 5 x 11 swept, a small 11! pool, small quotes

Why: ``orchestrator.statistical_bound.tail_bound`` estimates the optimum of a space too large to sweep from
random designs' values (the lower tail's power law) with a lower confidence limit; its nominal confidence rests
on that law, so how often it holds is measured here, where the optimum is known, beside the classical Weibull of
group minima (``weibull_bound``) whose plug-in interval takes its fitted shape and scale as exact.

- *Swept cases* (the 11 x 8 lattice, the 11 x 7 x 11 plate): every design evaluated once at the search fidelity
  (the sweep's screening, every value kept, through the Evaluator on a process pool), so the optimum at that
  fidelity is known; a sampling draws random designs uniformly, with replacement, from those values.
- *11!* (the 11 x 11 lattice, whose optimum is certified under both rules, ``orchestrator/known_optima.json``):
  one pool of random designs evaluated once, cut into disjoint samplings (so the samplings are independent);
  the optimum is the certified order's value at the search fidelity.
- *Quotes*: the estimate for the 12-column lattice (12! orders) and the 11 x 11 x 11 plate from a modest number
  of random designs each: a statistical estimate, never a certificate.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass

import numpy as np

from orchestrator.design import DesignSpace
from orchestrator.executors import make_executor
from orchestrator.known_optima import known_optima
from orchestrator.loop import Evaluator, run_search
from orchestrator.objective import SEARCH, LatticeObjective, close_instances
from orchestrator.search import make_search
from orchestrator.statistical_bound import KIND, TailBound, default_tail, random_values, tail_bound, weibull_bound

from .common import (
    FULL_HORIZON,
    TWELVE_MATERIALS_TEXT,
    lattice_fmu,
    narrow_lattice,
    order_text,
    screened_values,
    twelve_column_lattice,
)
from .measurements import Page, Run, Table, write_page

RULES = ("receiver", "mean")
PLATE_SCENE = "plate_11x11x11"
PLATE_FINDING_LAYERS = 7  # the plate whose optimum bench.plate_finding certifies (this scene's 3 x 3 patch)
PLUG_IN_GROUPS = 20  # group minima of the classical fit, as Golden and Alt's studies use


@dataclass(frozen=True)
class Case:
    """A validation case: the values a sampling draws from and the optimum they must hold."""

    label: str
    optimum: float  # at the search fidelity
    optimum_source: str
    values: np.ndarray
    block: int  # > 0: a pool cut into disjoint blocks of this many, one per sampling; 0: every design's value


@dataclass(frozen=True)
class Coverage:
    """One row: ``samplings`` independent samplings of ``designs`` random designs each."""

    case: Case
    designs: int
    samplings: int
    held: int
    median_width: float  # best seen - lower limit (inf when unbounded)
    unbounded: int
    median_error: float  # estimate - optimum
    median_gap: float  # best seen - optimum
    plug_in_held: int
    plug_in_width: float
    median_exponent_upper: float  # the exponent's upper limit the interval used (inf: unbounded)


def sampling(case: Case, index: int, designs: int, seed: int) -> np.ndarray:
    """Sampling ``index``: the start of its own block of the pool, or drawn with replacement from every value."""
    if case.block:
        if designs > case.block or (index + 1) * case.block > len(case.values):
            raise ValueError(f"{case.label}: the pool has no block {index} of {designs} designs")
        return case.values[index * case.block : index * case.block + designs]
    rng = np.random.default_rng([seed, index])
    return case.values[rng.integers(0, len(case.values), designs)]


def validate(case: Case, designs: int, samplings: int, confidence: float, seed: int) -> Coverage:
    held = plug_in_held = unbounded = 0
    widths, errors, gaps, plug_in_widths, uppers = [], [], [], [], []
    for index in range(samplings):
        drawn = sampling(case, index, designs, seed)
        bound = tail_bound(drawn, confidence)
        held += bound.holds(case.optimum)
        unbounded += not bound.bounded
        widths.append(bound.best_seen - bound.lower)
        uppers.append(bound.exponent_upper)
        errors.append(bound.estimate - case.optimum)
        gaps.append(bound.best_seen - case.optimum)
        plug_in = weibull_bound(drawn, designs // PLUG_IN_GROUPS, confidence)
        plug_in_held += plug_in.holds(case.optimum)
        plug_in_widths.append(plug_in.best_seen - plug_in.lower)
    return Coverage(
        case,
        designs,
        samplings,
        held,
        statistics.median(widths),
        unbounded,
        statistics.median(errors),
        statistics.median(gaps),
        plug_in_held,
        statistics.median(plug_in_widths),
        statistics.median(uppers),
    )


def screening_function(fmu, columns: int, rule: str):
    (screening,) = LatticeObjective(
        str(fmu), DesignSpace.permutations(columns), FULL_HORIZON, parameters={"diagonal_rule": rule}
    ).tasks(SEARCH)
    return screening


def random_pool(fmu, columns: int, rule: str, designs: int, workers: int, seed: int) -> np.ndarray:
    """``designs`` uniformly random orders' values at the search fidelity, through the Evaluator."""
    screening = screening_function(fmu, columns, rule)
    with make_executor("process", workers) as executor:
        evaluator = Evaluator(executor)
        values = random_values(
            lambda drawn: evaluator.evaluate([(screening, d) for d in drawn]),
            DesignSpace.permutations(columns),
            designs,
            np.random.default_rng(seed),
        )
    close_instances()
    return np.array(values, dtype=float)


def swept_case(label: str, fmu, columns: int, rule: str, workers: int, source: str) -> Case:
    space = DesignSpace.permutations(columns)
    swept = screened_values(fmu, space, workers, parameters={"diagonal_rule": rule})
    values = np.array([v for v in swept if v is not None], dtype=float)
    if len(values) != space.size:
        raise SystemExit(f"{label}: {space.size - len(values)} designs failed in the sweep")
    best = int(np.argmin(values))
    return Case(label, float(values[best]), f"{source}: {order_text(space.unrank(best))}, every order swept", values, 0)


def certified_case(fmu, rule: str, samplings: int, block: int, workers: int, seed: int) -> Case:
    known = next(k for k in known_optima() if k.rows == 11 and k.columns == 11 and k.diagonal_rule == rule)
    if not known.certified:
        raise SystemExit(f"11 x 11, {rule}: the recorded optimum is not certified")
    with make_executor("serial") as executor:
        (at_search,) = Evaluator(executor).evaluate([(screening_function(fmu, 11, rule), known.order)])
    close_instances()
    if not at_search.ok:
        raise SystemExit(f"11 x 11, {rule}: the certified order failed at the search fidelity: {at_search.message}")
    values = random_pool(fmu, 11, rule, samplings * block, workers, seed)
    if values.min() < at_search.value:
        raise SystemExit(f"11 x 11, {rule}: a random design beat the certified optimum at the search fidelity")
    source = (
        f"certified {order_text(known.order)}: {known.peak:.3f} N at full fidelity, {at_search.value:.3f} N at the "
        "search fidelity"
    )
    return Case(f"11 x 11 (11!), {rule}", float(at_search.value), source, values, block)


def coverage_row(row: Coverage, confidence: float) -> tuple:
    width = "unbounded" if not np.isfinite(row.median_width) else f"{row.median_width:.2f}"
    return (
        row.case.label,
        f"{row.case.optimum:.3f}",
        f"{row.designs:,}",
        f"{row.held}/{row.samplings} = {row.held / row.samplings:.0%}",
        f"{confidence:.0%}",
        width,
        f"{row.unbounded}",
        f"{row.median_error:+.2f}",
        f"{row.median_gap:.2f}",
        f"{row.median_exponent_upper:.2f}",
        f"{row.plug_in_held}/{row.samplings} = {row.plug_in_held / row.samplings:.0%}",
        f"{row.plug_in_width:.2f}",
    )


NEAR = (5, 50)  # ranks among the values evaluated between which the tail's exponent near the optimum is read


def fit_rank(case: Case, designs: int) -> int:
    """The rank among the case's values at the depth a fit of ``designs`` random designs reaches (its tail's
    share of them)."""
    return max(NEAR[1] + 1, round(len(case.values) * default_tail(designs) / designs))


def local_exponents(case: Case, designs: int) -> tuple[float, float]:
    """The tail's exponent a (the share within x of the optimum grows as x^a) read from the case's own values
    and its known optimum: between the NEAR ranks, and from the last of them to ``fit_rank`` (the depth a fit
    of ``designs`` sees)."""
    ordered = np.sort(case.values)
    ranks = (*NEAR, fit_rank(case, designs))
    x = [ordered[r - 1] - case.optimum for r in ranks]
    return (
        float(np.log(ranks[1] / ranks[0]) / np.log(x[1] / x[0])),
        float(np.log(ranks[2] / ranks[1]) / np.log(x[2] / x[1])),
    )


def annealed(fmu, columns: int, rule: str, budget: int, workers: int) -> float:
    """The best value of an annealing run of ``budget`` designs at the search fidelity: an answer to quote."""
    space = DesignSpace.permutations(columns)
    objective = LatticeObjective(str(fmu), space, FULL_HORIZON, parameters={"diagonal_rule": rule})
    with make_executor("process", workers) as executor:
        searched = run_search(
            make_search("sa", space, 1, budget=budget), objective, budget, Evaluator(executor), method_name="sa", seed=1
        )
    close_instances()
    if searched.best_value is None:
        raise SystemExit(f"{columns} columns, {rule}: the annealing run found no design with a value")
    return float(searched.best_value)


def quote_rows(fmu, columns: int, label: str, args, seed: int) -> list[tuple]:
    """Under each rule: the bound from ``args.quote_designs`` random designs beside an annealing run's best."""
    rows = []
    for index, rule in enumerate(RULES):
        start = time.perf_counter()
        values = random_pool(fmu, columns, rule, args.quote_designs, args.workers, seed=seed + index)
        bound = tail_bound(values, args.confidence)
        answer = annealed(fmu, columns, rule, args.quote_search, args.workers)
        rows.append(
            quote_row(
                f"{label}, {rule}",
                DesignSpace.permutations(columns),
                bound,
                answer,
                time.perf_counter() - start,
            )
        )
    return rows


def quote_row(label: str, space: DesignSpace, bound: TailBound, answer: float, seconds: float) -> tuple:
    lower = f"{bound.lower:.2f}" if bound.bounded else "unbounded"
    if not bound.bounded:
        within = "-"
    elif answer < bound.lower:
        within = "below the limit: the tail's law does not hold here"
    else:
        within = f"{bound.within(answer):.2f} ({bound.within(answer) / answer:.1%})"
    return (
        label,
        f"{space.size:,}",
        f"{bound.designs:,}",
        f"{bound.best_seen:.2f}",
        f"{min(bound.estimate, answer):.2f}",
        lower,
        f"{answer:.2f}",
        within,
        f"{bound.exponent:.2f} (upper {bound.exponent_upper:.2f})",
        f"{seconds:.0f}",
    )


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(
        __doc__, quick="11 x 6 and 11 x 5 x 11 swept, 20 samplings of 200 and 400 designs, quotes of 200 designs"
    )
    parser.add_argument("--samplings", type=int, default=20, help="independent samplings per row (at least 20)")
    parser.add_argument("--designs", default="500,1000,2000", help="random designs per sampling, comma list")
    parser.add_argument("--quote-designs", type=int, default=1000, help="random designs of each quote")
    parser.add_argument("--quote-search", type=int, default=500, help="designs of the annealing run quoted")
    parser.add_argument("--confidence", type=float, default=0.95, help="the interval's nominal confidence")
    parser.add_argument("--workers", type=int, default=2, help="processes evaluating designs")
    args = parser.parse_args(argv)
    lattice_columns, plate_layers = 8, 7
    if args.quick:
        lattice_columns, plate_layers, args.designs, args.quote_designs, args.quote_search = 6, 5, "200,400", 200, 50
    try:
        sizes = tuple(int(s) for s in args.designs.split(","))
    except ValueError:
        parser.error(f"--designs: a comma list of whole numbers >= 100, got {args.designs!r}")
    if args.samplings < 20 or min(sizes) < 100 or args.quote_designs < 100 or not 0 < args.confidence < 1:
        parser.error("--samplings >= 20, --designs >= 100 each, --quote-designs >= 100, 0 < --confidence < 1")
    if args.quote_search < 10:
        parser.error("--quote-search >= 10")

    cases: list[Case] = []
    started = time.perf_counter()
    with narrow_lattice(lattice_columns) as (_, fmu):
        for rule in RULES:
            cases.append(
                swept_case(f"11 x {lattice_columns}, {rule}", fmu, lattice_columns, rule, args.workers, "the optimum")
            )
    with lattice_fmu(scene=PLATE_SCENE, cols=plate_layers) as fmu:
        for rule in RULES:
            cases.append(
                swept_case(
                    f"11 x {plate_layers} x 11 plate, {rule}",
                    fmu,
                    plate_layers,
                    rule,
                    args.workers,
                    "the optimum"
                    + (" (certified on the plate's finding page)" if plate_layers == PLATE_FINDING_LAYERS else ""),
                )
            )
    with narrow_lattice(11) as (_, fmu):
        for index, rule in enumerate(RULES):
            cases.append(certified_case(fmu, rule, args.samplings, max(sizes), args.workers, seed=37 + index))
    evaluation_seconds = time.perf_counter() - started

    rows = []
    for case_index, case in enumerate(cases):
        for size_index, size in enumerate(sizes):
            rows.append(validate(case, size, args.samplings, args.confidence, seed=100 * case_index + size_index))

    quotes = []
    with twelve_column_lattice() as fmu:
        quotes += quote_rows(fmu, 12, "11 x 12 lattice, 12 materials", args, seed=1200)
    with lattice_fmu(scene=PLATE_SCENE) as fmu:
        quotes += quote_rows(fmu, 11, "11 x 11 x 11 plate", args, seed=1100)

    coverages = [r.held / r.samplings for r in rows]
    plug_ins = [r.plug_in_held / r.samplings for r in rows]
    page = Page(
        name=run.name,
        title="Statistical bound: coverage where the optimum is known, and quotes where it is not",
        headline=(
            f"the {args.confidence:.0%} lower limit held the known optimum in {min(coverages):.0%}-"
            f"{max(coverages):.0%} of {args.samplings} samplings per case ({min(sizes):,}-{max(sizes):,} random "
            f"designs; the Weibull plug-in {min(plug_ins):.0%}-{max(plug_ins):.0%}): a statistical estimate, "
            "not a certificate"
        ),
        summary=(
            f"`orchestrator.statistical_bound.tail_bound` fits the k smallest of n random designs' values "
            f"(k about 2 sqrt(n)) as the lower tail of a power law, and gives the optimum's estimate and a lower "
            f"limit of nominal confidence {args.confidence:.0%} (the tail exponent at its upper confidence limit, "
            f"an exact pivot for the lower end). Its coverage is how many of {args.samplings} independent "
            f"samplings' intervals [lower limit, best seen] held the optimum at the search fidelity (the sweep's "
            f"screening: {FULL_HORIZON:g} s scenes screened over the search horizon). Swept cases: every order "
            f"of the 11 x {lattice_columns} lattice and of the 11 x {plate_layers} x 11 plate (scene "
            f"{PLATE_SCENE} with {plate_layers} layers) evaluated once; a sampling draws uniformly, with "
            f"replacement, from those values. 11!: one pool of {args.samplings} x {max(sizes):,} random orders "
            f"of the 11 x 11 lattice per rule, evaluated once and cut into {args.samplings} disjoint samplings "
            f"(a smaller sampling is the start of its block), so the samplings are independent and no design is "
            f"evaluated twice; the optimum is the certified one. Beside it, the classical Weibull of "
            f"{PLUG_IN_GROUPS} group minima (`weibull_bound`, Golden and Alt) with its plug-in interval. "
            f"Evaluating every value took {evaluation_seconds:.0f} s on {args.workers} processes. The bound is "
            f"a {KIND}."
        ),
        tables=(
            Table(
                (
                    "case",
                    "optimum at search fidelity (N)",
                    "designs per sampling",
                    "coverage",
                    "nominal",
                    "median best seen - lower limit (N)",
                    "unbounded",
                    "median estimate - optimum (N)",
                    "median best seen - optimum (N)",
                    "median exponent used",
                    "Weibull plug-in coverage",
                    "its median width (N)",
                ),
                tuple(coverage_row(r, args.confidence) for r in rows),
                caption="**Coverage where the optimum is known:**",
            ),
            Table(
                (
                    "case",
                    "optimum from",
                    "values",
                    f"tail exponent, {NEAR[0]}th-{NEAR[1]}th smallest",
                    f"{NEAR[1]}th smallest to the depth a fit of {max(sizes):,} designs sees",
                ),
                tuple(
                    (
                        c.label,
                        c.optimum_source,
                        f"{len(c.values):,}",
                        *(f"{a:.2f}" for a in local_exponents(c, max(sizes))),
                    )
                    for c in cases
                ),
                caption=(
                    "Where the optimum comes from, and the tail's exponent read from every value evaluated for the "
                    "case against that optimum: the interval holds when the exponent it uses (the table above) is "
                    "at least the one near the optimum; a fit at a sampling's scale cannot see that one:"
                ),
            ),
            Table(
                (
                    "space",
                    "designs",
                    "random designs",
                    "best seen (N)",
                    "estimate (N)",
                    f"lower limit, {args.confidence:.0%} (N)",
                    f"an annealing run's best, {args.quote_search} designs (N)",
                    f"it is within this of the optimum, {args.confidence:.0%} (N)",
                    "tail exponent",
                    "wall s",
                ),
                tuple(quotes),
                caption=(
                    "**Quoted where no sweep fits** (the search fidelity; a statistical estimate, not a certificate; "
                    "the estimate is at most the annealing run's best, a design's value; wall s: the random designs, "
                    "the fit and the annealing run):"
                ),
            ),
        ),
        notes=(
            (
                f"The 12-column lattice's materials: {TWELVE_MATERIALS_TEXT}. "
                "An answer of value v lies within v - (lower limit) of the optimum with the nominal probability, if "
                "the tail law holds; the coverage measured above is how far that can be trusted. A row's coverage "
                f"is a count out of {args.samplings}: its own uncertainty is several percent."
            ),
        ),
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
