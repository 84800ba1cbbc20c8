"""Search the material order that minimises the peak backplate force (a thin CLI over orchestrator/).

    python orchestrator/run.py                         # the default job: CMA-ES, PSO, annealing + baselines
    python orchestrator/run.py --method cmaes --budget 2000 --repeats 3
    python orchestrator/run.py --case F_total=600,1200,2400 --aggregate worst
    python orchestrator/run.py --executor dask --scheduler tcp://10.0.0.5:8786
    python orchestrator/run.py --out results --resume  # continue an interrupted run

Errors are one line on stderr with exit code 2 (a traceback only with --debug); an interrupted run exits
130 (Ctrl-C) or 143 (SIGTERM) and keeps every finished evaluation in OUT/journal.jsonl.
"""
from __future__ import annotations

import argparse
import math
import signal
import sys
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from orchestrator.executors import EXECUTORS  # noqa: E402
from orchestrator.objective import AGGREGATES, OBJECTIVES  # noqa: E402
from orchestrator.search import SEARCHES  # noqa: E402
from orchestrator.study import MAX_HORIZON, StudyConfig  # noqa: E402

EXIT_USAGE = 2
EXIT_NO_RESULT = 3


class UsageError(ValueError):
    """Bad input: one line, exit 2."""


class Interrupted(BaseException):
    """SIGTERM, handled like Ctrl-C (a BaseException, so no evaluation guard swallows it)."""


def finite(name: str, low: float | None = None, high: float | None = None, allow_zero: bool = False):
    """An argparse type: a finite float in (low, high], or 0 when allow_zero (meaning: the default)."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number, got {text!r}") from None
        if allow_zero and value == 0:
            return value
        if not math.isfinite(value) or (low is not None and value <= low) or (high is not None and value > high):
            bounds = f"in ({low:g}, {high:g}]" if low is not None and high is not None else (
                f"> {low:g}" if low is not None else "finite")
            raise argparse.ArgumentTypeError(f"{name} must be a finite number {bounds}, got {text!r}")
        return value
    return parse


def integer(name: str, low: int, high: int | None = None):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be an integer, got {text!r}") from None
        if value < low or (high is not None and value > high):
            upper = f" and at most {high}" if high is not None else ""
            raise argparse.ArgumentTypeError(f"{name} must be at least {low}{upper}, got {value}")
        return value
    return parse


def parse_case(text: str) -> tuple[str, list[str]]:
    name, sep, values = text.partition("=")
    name = name.strip()
    items = [v.strip() for v in values.split(",")] if sep else []
    if not name or not sep or not items or any(not v for v in items):
        raise argparse.ArgumentTypeError(f"--case {text!r}: expected NAME=V1,V2,... (a parameter of the FMU and "
                                         f"a comma-separated list of values)")
    return name, items


class Parser(argparse.ArgumentParser):
    def error(self, message: str):  # one line, exit 2 (argparse's own format, without the usage block)
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    defaults = StudyConfig()
    parser = Parser(description=__doc__.split("\n\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--method", nargs="+", default=list(defaults.methods),
                        choices=list(SEARCHES) + ["exhaustive", "all"],
                        help="searches and baselines to run; exhaustive: every order (checkpointed, see --checkpoint)")
    parser.add_argument("--budget", type=integer("--budget", 1, 10**9), default=defaults.budget,
                        help="evaluations of distinct orders per run (never exceeded)")
    parser.add_argument("--seed", type=integer("--seed", 0, 2**32 - 1001), default=defaults.seed, help="first seed")
    parser.add_argument("--repeats", type=integer("--repeats", 1, 10**6), default=defaults.repeats,
                        help="runs per method: seeds S..S+R-1")
    parser.add_argument("--objective", choices=list(OBJECTIVES), default=defaults.objective,
                        help="sampled: the study's 0.01 s samples; continuous: the true peak")
    parser.add_argument("--case", action="append", type=parse_case, default=[], metavar="NAME=V1,V2,...",
                        help="load cases (repeatable; the cases are the product of the lists), e.g. F_total=600,1200")
    parser.add_argument("--aggregate", choices=list(AGGREGATES), default=None,
                        help="how the cases make one value (default worst; only with --case)")
    parser.add_argument("--executor", choices=list(EXECUTORS), default=defaults.executor)
    parser.add_argument("--workers", type=integer("--workers", 1, 4096), default=None,
                        help="worker processes (default: all cores)")
    parser.add_argument("--scheduler", default=None,
                        help="address of a Dask scheduler (with --executor dask); none: a local Dask cluster")
    parser.add_argument("--out", default=defaults.out, help="report folder (holds the journal of the run)")
    parser.add_argument("--resume", action="store_true",
                        help="continue the run in --out from its journal (same settings), simulating no order twice")
    parser.add_argument("--checkpoint", default=None,
                        help="folder of the exhaustive sweep's finished chunks (default OUT/exhaustive); "
                             "a sweep started again with it skips them")
    parser.add_argument("--chunk-size", type=integer("--chunk-size", 1, 10**9), default=None,
                        help="orders per chunk of the exhaustive sweep (default: about 200 chunks)")
    parser.add_argument("--confirm-exhaustive", action="store_true",
                        help="run an exhaustive sweep beyond 10! orders (only with --executor dask)")
    parser.add_argument("--scene", default=defaults.scene, help="scene name from scenes/ or a .json path")
    parser.add_argument("--fmu", default=None, help="FMU to use (default: models/<scene's FMU>, built if missing)")
    parser.add_argument("--horizon", type=finite("--horizon", 0, MAX_HORIZON), default=None,
                        help=f"full scene horizon in s, at most {MAX_HORIZON:g} (default: the scene's)")
    parser.add_argument("--search-horizon", type=finite("--search-horizon", 0, MAX_HORIZON, allow_zero=True),
                        default=defaults.search_horizon,
                        help="horizon of the searches' cheaper objective in s (the finalists are re-evaluated "
                             "over the full horizon); 0: search over the full horizon")
    parser.add_argument("--search-rtol", type=finite("--search-rtol", 1e-13, 1e-2, allow_zero=True),
                        default=defaults.search_rtol,
                        help="solver tolerance during the searches, in (1e-13, 1e-2]; 0: the FMU's default")
    parser.add_argument("--load", type=finite("--load"), default=None, dest="F_total", help="total load F_total in N")
    parser.add_argument("--load-angle", type=finite("--load-angle"), default=None, dest="load_angle",
                        help="load angle in degrees")
    parser.add_argument("--diagonal-rule", choices=["receiver", "mean"], default=None,
                        help="diagonal spring constants (receiver reproduces the study)")
    parser.add_argument("--finalists", type=integer("--finalists", 1, 1000), default=defaults.finalists,
                        help="best orders per run re-evaluated over the full horizon")
    parser.add_argument("--time-limit", type=finite("--time-limit", 0), default=defaults.time_limit,
                        help="seconds one evaluation may take before it is failed")
    parser.add_argument("--no-local-check", action="store_true", help="skip the final descent of the best order")
    parser.add_argument("--no-which-model", action="store_true",
                        help="do not search under the other diagonal rule")
    parser.add_argument("--which-model-budget", type=integer("--which-model-budget", 1, 10**9),
                        default=defaults.which_model_budget,
                        help="evaluations of each search under the other diagonal rule")
    parser.add_argument("--sensitivity-budget", type=integer("--sensitivity-budget", 1, 10**9),
                        default=defaults.sensitivity_budget,
                        help="evaluations of the short search for each variation of the case")
    parser.add_argument("--no-sensitivity", action="store_true",
                        help="do not evaluate the chosen order under the standard variations of the case")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--debug", action="store_true", help="tracebacks instead of one-line errors")
    return parser


def parse_args(argv=None) -> tuple[StudyConfig, argparse.Namespace]:
    parser = build_parser()
    args = parser.parse_args(argv)
    parameters = {name: getattr(args, name) for name in ("F_total", "load_angle", "diagonal_rule")}
    cases: dict[str, list[str]] = {}
    for name, values in args.case:
        if name in cases:
            parser.error(f"--case {name}: given twice; give its values in one list")
        cases[name] = values
    try:
        config = StudyConfig(
            methods=tuple(args.method), budget=args.budget, seed=args.seed, repeats=args.repeats,
            objective=args.objective, executor=args.executor, workers=args.workers, scheduler=args.scheduler,
            out=args.out, scene=args.scene, fmu=args.fmu, horizon=args.horizon,
            search_horizon=args.search_horizon or None, search_rtol=args.search_rtol or None,
            parameters={k: v for k, v in parameters.items() if v is not None}, cases=cases,
            aggregate=args.aggregate, finalists=args.finalists, time_limit=args.time_limit,
            local_check=not args.no_local_check, which_model=not args.no_which_model,
            sensitivity=not args.no_sensitivity, which_model_budget=args.which_model_budget,
            sensitivity_budget=args.sensitivity_budget, checkpoint=args.checkpoint, chunk_size=args.chunk_size,
            confirm_exhaustive=args.confirm_exhaustive, resume=args.resume, progress=not args.no_progress)
    except ValueError as exc:
        parser.error(str(exc))
    return config, args


def check_out_writable(out: str) -> None:
    folder = Path(out)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        probe = folder / ".write-test"
        probe.write_text("")
        probe.unlink()
    except OSError as exc:
        raise UsageError(f"--out {out}: not a writable folder ({exc.strerror or exc})") from None


def check_parameters(config: StudyConfig, fmu_path) -> None:
    """Every FMU parameter the run sets (scene options and --case values) exists and is in the FMU's range;
    --case values are converted to numbers here, before any simulation."""
    from orchestrator.simulation import model_description

    description = model_description(fmu_path)
    variables = {v.name: v for v in description.modelVariables if v.causality == "parameter"}
    scalar = sorted(n for n in variables if "[" not in n)

    def convert(name: str, text, source: str):
        variable = variables.get(name)
        if variable is None:
            raise UsageError(f"{source} {name}: not a parameter of {Path(fmu_path).name}; allowed: {', '.join(scalar)}")
        if name == "diagonal_rule":
            rules = {"receiver": "receiver", "mean": "mean", "0": "receiver", "1": "mean"}
            if str(text) not in rules:
                raise UsageError(f"{source} diagonal_rule={text}: allowed values are receiver, mean (or 0, 1)")
            return rules[str(text)]
        try:
            value = float(text) if variable.type == "Real" else int(str(text))
        except ValueError:
            raise UsageError(f"{source} {name}={text}: not a number") from None
        low = float(variable.min) if getattr(variable, "min", None) not in (None, "") else -math.inf
        high = float(variable.max) if getattr(variable, "max", None) not in (None, "") else math.inf
        if not math.isfinite(value) or not low <= value <= high:
            raise UsageError(f"{source} {name}={text}: allowed values are finite numbers in [{low:g}, {high:g}]")
        return value

    for name, value in config.parameters.items():
        option = {"F_total": "--load", "load_angle": "--load-angle", "diagonal_rule": "--diagonal-rule"}.get(name, name)
        config.parameters[name] = convert(name, value, option)
    for name, values in config.cases.items():
        config.cases[name] = [convert(name, value, "--case") for value in values]


def _on_sigterm(signum, frame):
    raise Interrupted()


def main(argv=None) -> int:
    config, args = parse_args(argv)
    debug = args.debug
    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        return _main(config)
    except (KeyboardInterrupt, Interrupted) as exc:
        code = 143 if isinstance(exc, Interrupted) else 130
        print(f"interrupted: finished evaluations are kept in {Path(config.out) / 'journal.jsonl'}; "
              f"continue with the same options and --resume", file=sys.stderr)
        return code
    except Exception as exc:  # noqa: BLE001 - one line for users, the traceback with --debug
        if debug:
            raise
        message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        print(f"run.py: error: {message}", file=sys.stderr)
        return EXIT_USAGE
    finally:
        signal.signal(signal.SIGTERM, previous)


def _main(config: StudyConfig) -> int:
    from orchestrator.report import write_report
    from orchestrator.study import ensure_fmu, run_study

    check_out_writable(config.out)
    config.fmu = str(ensure_fmu(config.scene, config.fmu))
    check_parameters(config, config.fmu)
    study = run_study(config)
    report = write_report(study)
    best = study.best_verified()
    if best is None:
        reasons = sorted({e.message for run in study.runs for e in run.evaluations if not e.ok and not e.censored}
                         | {v.message for v in study.verified.values() if not v.ok})
        print(f"no result: every evaluation failed ({reasons[0] if reasons else 'no evaluation ran'}); "
              f"report: {report}", file=sys.stderr)
        return EXIT_NO_RESULT
    cases = f" ({config.aggregate or 'worst'} of {len(study.objective.cases)} cases)" if config.cases else ""
    print(f"best order {list(best.order)}: {best.peak:.4f} N ({config.objective} peak over {study.horizon:g} s"
          f"{cases}), {best.details.get('peak_continuous', float('nan')):.4f} N continuous")
    if study.which_model:
        for rule in ("receiver", "mean"):
            entry = study.which_model.get(rule)
            if entry:
                print(f"optimum under the {rule} rule: {entry['order']} ({entry.get('peak_receiver', float('nan')):.1f} N "
                      f"receiver, {entry.get('peak_mean', float('nan')):.1f} N mean)")
    print(f"report: {report}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
