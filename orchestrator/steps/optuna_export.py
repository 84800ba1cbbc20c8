"""The evaluations in an Optuna storage (``--export-optuna STORAGE``), for optuna-dashboard and the tools of
optimisation users; the export itself is ``orchestrator.optuna_export``. It simulates nothing; a storage that
cannot take the export is reported in the report and on stderr, never losing the study's results."""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass

from ..options import NO_NUMBER, option
from ..optuna_export import ExportedStudy, check_storage, export
from ..study import Step, StudyContext
from .searches import Searches


@dataclass(frozen=True)
class OptunaExportConfig:
    export_optuna: str | None = option(
        None,
        "write every evaluation of the searches as an Optuna trial into STORAGE, an Optuna RDB URL such as "
        "sqlite:///study.db (one study per diagonal rule; needs the optuna extra); optuna-dashboard STORAGE shows "
        "it",
        metavar="STORAGE",
        study=NO_NUMBER,
        show_default="none",
    )

    def __post_init__(self):
        if self.export_optuna is not None:  # with the options: before the FMU is built
            check_storage(self.export_optuna)


@dataclass(frozen=True)
class OptunaExportResult:
    storage: str
    studies: tuple[ExportedStudy, ...]
    error: str | None  # why the export did not happen (the study's results are kept)
    seconds: float = 0.0  # how long writing the trials took


class OptunaExport(Step):
    name = "optuna_export"
    title = "Optuna export"
    template = "optuna_export.html.j2"
    Config = OptunaExportConfig

    def applies(self, context: StudyContext) -> bool:
        return self.config.export_optuna is not None

    def check(self, context: StudyContext) -> None:
        if self.config.export_optuna is not None:
            check_storage(self.config.export_optuna)

    def run(self, context: StudyContext) -> OptunaExportResult:
        storage = self.config.export_optuna
        searched = context.result(Searches)
        journal = context.evaluator.journal
        start = time.perf_counter()
        try:
            studies = export(
                storage,
                searched.runs if searched else (),
                tuple(context.case.outputs),
                context.case.columns,
                list(context.case.materials.names),
                context.case.describe(context.fmu).line(),
                getattr(journal, "run_id", "") or "study",
                context.fmu.sha256,
                context.progress,
            )
        except Exception as exc:  # noqa: BLE001 - a storage error is reported; the results are kept
            message = str(exc).splitlines()[0] if str(exc).strip() else type(exc).__name__
            print(f"--export-optuna {storage}: not exported: {message}", file=sys.stderr)
            return OptunaExportResult(storage, (), message, time.perf_counter() - start)
        return OptunaExportResult(storage, tuple(studies), None, time.perf_counter() - start)


__all__ = ["OptunaExport", "OptunaExportConfig", "OptunaExportResult"]
