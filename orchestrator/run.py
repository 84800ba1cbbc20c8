"""Search the material order that minimises the peak backplate force (a thin CLI over orchestrator/).

    python orchestrator/run.py                         # the default job: CMA-ES, PSO, annealing + baselines
    python orchestrator/run.py --method cmaes --budget 2000 --repeats 3
    python orchestrator/run.py --executor dask --scheduler tcp://10.0.0.5:8786
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from orchestrator.evaluate import OBJECTIVES  # noqa: E402
from orchestrator.executors import EXECUTORS  # noqa: E402
from orchestrator.search import SEARCHES  # noqa: E402
from orchestrator.study import StudyConfig  # noqa: E402


def parse_args(argv=None) -> StudyConfig:
    defaults = StudyConfig()
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--method", nargs="+", default=list(defaults.methods),
                        choices=list(SEARCHES) + ["all"], help="searches and baselines to run")
    parser.add_argument("--budget", type=int, default=defaults.budget,
                        help="evaluations of distinct orders per run (never exceeded)")
    parser.add_argument("--seed", type=int, default=defaults.seed, help="first seed")
    parser.add_argument("--repeats", type=int, default=defaults.repeats, help="runs per method: seeds S..S+R-1")
    parser.add_argument("--objective", choices=sorted(OBJECTIVES), default=defaults.objective,
                        help="sampled: the study's 0.01 s samples; continuous: the true peak")
    parser.add_argument("--executor", choices=list(EXECUTORS), default=defaults.executor)
    parser.add_argument("--workers", type=int, default=None, help="worker processes (default: all cores)")
    parser.add_argument("--scheduler", default=None,
                        help="address of a Dask scheduler (with --executor dask); none: a local Dask cluster")
    parser.add_argument("--out", default=defaults.out, help="report folder")
    parser.add_argument("--scene", default=defaults.scene, help="scene name from scenes/ or a .json path")
    parser.add_argument("--fmu", default=None, help="FMU to use (default: models/<scene's FMU>, built if missing)")
    parser.add_argument("--horizon", type=float, default=None, help="full scene horizon in s (default: the scene's)")
    parser.add_argument("--search-horizon", type=float, default=defaults.search_horizon,
                        help="horizon of the searches' cheaper objective in s (the finalists are re-evaluated "
                             "over the full horizon); 0: search over the full horizon")
    parser.add_argument("--search-rtol", type=float, default=defaults.search_rtol,
                        help="solver tolerance during the searches; 0: the FMU's default")
    parser.add_argument("--load", type=float, default=None, dest="F_total", help="total load F_total in N")
    parser.add_argument("--load-angle", type=float, default=None, dest="load_angle", help="load angle in degrees")
    parser.add_argument("--diagonal-rule", choices=["receiver", "mean"], default=None,
                        help="diagonal spring constants (receiver reproduces the study)")
    parser.add_argument("--finalists", type=int, default=defaults.finalists,
                        help="best orders per run re-evaluated over the full horizon")
    parser.add_argument("--no-local-check", action="store_true", help="skip the swap/insertion check of the best")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    parameters = {name: getattr(args, name) for name in ("F_total", "load_angle", "diagonal_rule")}
    try:
        return StudyConfig(
            methods=tuple(args.method), budget=args.budget, seed=args.seed, repeats=args.repeats,
            objective=args.objective, executor=args.executor, workers=args.workers, scheduler=args.scheduler,
            out=args.out, scene=args.scene, fmu=args.fmu, horizon=args.horizon,
            search_horizon=args.search_horizon or None, search_rtol=args.search_rtol or None,
            parameters={k: v for k, v in parameters.items() if v is not None}, finalists=args.finalists,
            local_check=not args.no_local_check, progress=not args.no_progress)
    except ValueError as exc:
        parser.error(str(exc))


def main(argv=None) -> int:
    config = parse_args(argv)
    from orchestrator.report import write_report
    from orchestrator.study import run_study

    study = run_study(config)
    report = write_report(study)
    best = study.best_verified()
    if best is not None:
        print(f"best order {list(best.order)}: {best.peak(config.objective):.4f} N ({config.objective} peak over "
              f"{study.horizon:g} s), {best.peak_continuous:.4f} N continuous")
    print(f"report: {report}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
