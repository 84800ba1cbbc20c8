"""The starting designs a person gives (``--start``, ``--start-file``): their options, read and checked against
the design space once. The searches start from them, the finalists include them, and the Starts step compares
them with the answers, so they live below all three.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..design import Design
from ..optuna_export import designs_from_storage
from ..options import option
from ..search.starts import DESIGN_EXAMPLE, parse_design
from ..study import StudyContext
from ..types import Order

COMMENT = "#"


@dataclass(frozen=True)
class StartsConfig:
    start: tuple[str, ...] = option(
        (),
        "a design every search evaluates first and starts from: the material of each column, column 1 "
        f"(at the load) first, e.g. {DESIGN_EXAMPLE} (repeatable)",
        action="append",
        metavar="ORDER",
    )
    start_file: str | None = option(
        None,
        "starting designs, one per line as for --start (# starts a comment), or an Optuna storage "
        "(e.g. sqlite:///study.db, needs the optuna extra): the best trial of each of its studies (with several "
        "objectives, each study's Pareto front)",
        metavar="FILE",
        path=True,
        show_default="none",
    )

    def __post_init__(self):
        for text in self.start:
            parse_design(text)


def read_start_file(path: str) -> list[tuple[Design, str]]:
    """(design, where it was read) of each design of a start file or an Optuna storage."""
    if "://" in path:
        return [(design, f"--start-file {path}") for design in designs_from_storage(path)]
    try:
        text = Path(path).read_text()
    except OSError as exc:
        raise ValueError(f"--start-file {path}: cannot read it ({exc.strerror or exc})") from None
    found = []
    for number, line in enumerate(text.splitlines(), start=1):
        line = line.split(COMMENT, 1)[0].strip()
        if line:
            found.append((parse_design(line, f"--start-file {path}:{number}:"), f"--start-file {path}:{number}"))
    if not found:
        raise ValueError(f"--start-file {path}: no design in it (one design per line, e.g. {DESIGN_EXAMPLE})")
    return found


def starting_designs(context: StudyContext) -> tuple[Order, ...]:
    """The starting designs of the run, each checked against the design space (ValueError: one line)."""
    config = context.options(StartsConfig)
    given = [(parse_design(text), "--start") for text in config.start]
    if config.start_file:
        given += read_start_file(config.start_file)
    for design, where in given:
        context.case.space.check(design, where)
    return tuple(dict.fromkeys(design for design, _ in given))


__all__ = ["StartsConfig", "read_start_file", "starting_designs"]
