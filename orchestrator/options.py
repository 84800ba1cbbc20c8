"""Command-line options declared where they are used: on the fields of frozen config dataclasses.

Each config (the run's, the case's, each step's) declares its options with :func:`option`; the CLI builds one
argument group per config from those declarations (in the spirit of PythonFMU's per-module parsers), shows
every real default in ``--help``, and builds the config from what was given. ``given(config)`` says which
options the user spelled out, so that an option that means nothing in a run is refused, not ignored.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
from typing import Any, Callable, ClassVar, NoReturn

_GIVEN = "_options_given"
EXIT_USAGE = 2  # a command line that cannot run, as argparse exits
KEPT, NO_NUMBER, NOT_KEPT = "kept", "no number", "not kept"  # how a study file keeps an option


class Parser(argparse.ArgumentParser):
    """argparse's parser, with errors in one line (argparse's own words, without the usage block), exit 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")


def option(
    default: Any,
    help: str,
    *,
    flag: str | None = None,
    type: Callable[[str], Any] | None = None,
    choices: Any = None,
    nargs: str | int | None = None,
    metavar: str | None = None,
    action: str | None = None,
    show_default: str | None = None,
    study: str = KEPT,
    path: bool = False,
    short: str | None = None,
):
    """A dataclass field that is also a command-line option (``--name-with-dashes`` unless ``flag``).

    ``show_default`` replaces the shown default (e.g. "the scene's, 1200 N"); ``action`` "store_true" or
    "store_false" makes a flag (the field's default is then the value without the flag). ``study``: how a
    study file (``orchestrator.studyfile``) keeps it: ``KEPT``, ``NO_NUMBER`` (written as a comment: it changes
    no number) or ``NOT_KEPT`` (it belongs to one invocation); ``path``: the value may be a file's path (a
    study file writes it relative to itself); ``short``: a one-letter spelling beside the long one (``-o``)."""
    if study not in (KEPT, NO_NUMBER, NOT_KEPT):
        raise ValueError(f"study must be one of {KEPT}, {NO_NUMBER}, {NOT_KEPT}, got {study!r}")
    metadata = {
        "help": help,
        "flag": flag,
        "type": type,
        "choices": choices,
        "nargs": nargs,
        "metavar": metavar,
        "action": action,
        "show_default": show_default,
        "study": study,
        "path": path,
        "short": short,
    }
    if isinstance(default, (list, dict, set)):
        raise TypeError("option defaults must be immutable (use a tuple)")
    return dataclasses.field(default=default, metadata={"option": metadata})


def flag_of(config_type: type, name: str) -> str:
    """The command-line spelling of a config field."""
    meta = next(f for f in dataclasses.fields(config_type) if f.name == name).metadata["option"]
    return meta["flag"] or "--" + name.replace("_", "-")


def _shown(value: Any) -> str:
    if isinstance(value, tuple):
        return " ".join(str(v) for v in value) if value else "none"
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def add_options(parser: argparse.ArgumentParser, config_type: type, title: str, description: str | None = None) -> None:
    """An argument group of ``parser`` with ``config_type``'s options."""
    group = parser.add_argument_group(title, description)
    for f in dataclasses.fields(config_type):
        meta = f.metadata.get("option")
        if meta is None:
            continue
        shown = meta["show_default"] if meta["show_default"] is not None else _shown(f.default)
        help_text = meta["help"]
        if meta["action"] not in ("store_true", "store_false"):
            help_text += f" (default: {shown})"
        kwargs: dict[str, Any] = {
            "dest": f"{config_type.__name__}.{f.name}",
            "default": argparse.SUPPRESS,
            "help": help_text,
        }
        if meta["action"] == "append":
            kwargs["action"] = "append"
            kwargs["metavar"] = meta["metavar"] or f.name.upper()
        elif meta["action"]:
            kwargs["action"] = meta["action"]
        else:
            for key in ("type", "choices", "nargs", "metavar"):
                if meta[key] is not None:
                    kwargs[key] = meta[key]
            if meta["metavar"] is None and meta["choices"] is None:
                kwargs["metavar"] = f.name.upper()
        flags = [meta["short"]] if meta["short"] else []
        group.add_argument(*flags, meta["flag"] or "--" + f.name.replace("_", "-"), **kwargs)


def config_from(config_type: type, namespace: argparse.Namespace, **extra: Any):
    """``config_type`` built from the options given (the rest at their defaults); ``given(config)`` tells
    which were given. A ValueError from the config's own checks reaches the caller as it is."""
    prefix = f"{config_type.__name__}."
    values = {key[len(prefix) :]: value for key, value in vars(namespace).items() if key.startswith(prefix)}
    for name, value in values.items():
        meta = next(f for f in dataclasses.fields(config_type) if f.name == name).metadata["option"]
        if meta["nargs"] in ("+", "*") or isinstance(meta["nargs"], int):
            values[name] = tuple(value)
    config = config_type(**{**values, **extra})
    object.__setattr__(config, _GIVEN, frozenset(values))
    return config


def given(config: Any) -> frozenset[str]:
    """The fields of ``config`` that were given on the command line (none for a config built in code)."""
    return getattr(config, _GIVEN, frozenset())


def check_options(config: Any) -> None:
    """Each option's value checked by the option's own type and choices, wherever it came from (the command
    line, a study file, Python): one rule and one message per option. A ValueError names the first wrong one."""
    for f in dataclasses.fields(config):
        meta = f.metadata.get("option")
        if meta is None:
            continue
        value = getattr(config, f.name)
        flag = meta["flag"] or "--" + f.name.replace("_", "-")
        if meta["action"] in ("store_true", "store_false"):
            if not isinstance(value, bool):
                raise ValueError(f"{flag}: must be true or false, got {value!r}")
            continue
        if value is None:
            continue
        several = meta["action"] == "append" or meta["nargs"] in ("+", "*") or isinstance(meta["nargs"], int)
        for item in value if several and isinstance(value, (tuple, list)) else (value,):
            _check_value(flag, meta, item)


def _check_value(flag: str, meta: dict, value: Any) -> None:
    kind = meta["type"]
    if kind is not None:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f"{flag} must be {getattr(kind, 'expects', 'a number')}, got {value!r}")
        try:
            kind(str(value))
        except argparse.ArgumentTypeError as exc:
            raise ValueError(str(exc)) from None
    if meta["choices"] is not None and value not in meta["choices"]:
        raise ValueError(f"{flag} {value}: allowed values are {', '.join(map(str, meta['choices']))}")


# ---------------------------------------------------------------------------------------------- value types
@dataclasses.dataclass(frozen=True)
class Number:
    """An argparse type: a finite number in (low, high] ([low, high] with ``low_inclusive``), or 0 when
    ``allow_zero`` (meaning: none). ``expects`` names it in a study file's refusal."""

    flag: str
    low: float | None = None
    high: float | None = None
    low_inclusive: bool = False
    allow_zero: bool = False
    expects: ClassVar[str] = "a number"

    def __call__(self, text: str) -> float:
        flag, low, high, low_inclusive, allow_zero = self.flag, self.low, self.high, self.low_inclusive, self.allow_zero
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{flag} must be a number, got {text!r}") from None
        if allow_zero and value == 0:
            return value
        below = low is not None and (value < low if low_inclusive else value <= low)
        if not math.isfinite(value) or below or (high is not None and value > high):
            left = "[" if low_inclusive else "("
            if low is not None and high is not None:
                bounds = f"in {left}{low:g}, {high:g}]"
            elif low is not None:
                bounds = f">= {low:g}" if low_inclusive else f"> {low:g}"
            else:
                bounds = ""
            raise argparse.ArgumentTypeError(
                f"{flag} must be a finite number{' ' + bounds if bounds else ''}"
                f"{' (or 0: none)' if allow_zero else ''}, got {text!r}"
            )
        return value


@dataclasses.dataclass(frozen=True)
class Integer:
    """An argparse type: an integer in [low, high]. ``expects`` names it in a study file's refusal."""

    flag: str
    low: int
    high: int | None = None
    expects: ClassVar[str] = "an integer"

    def __call__(self, text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{self.flag} must be an integer, got {text!r}") from None
        if value < self.low or (self.high is not None and value > self.high):
            upper = f" and at most {self.high}" if self.high is not None else ""
            raise argparse.ArgumentTypeError(f"{self.flag} must be at least {self.low}{upper}, got {value}")
        return value


def number(
    flag: str,
    low: float | None = None,
    high: float | None = None,
    *,
    low_inclusive: bool = False,
    allow_zero: bool = False,
) -> Number:
    """The argparse type of a number option (see Number)."""
    return Number(flag, low, high, low_inclusive, allow_zero)


def integer(flag: str, low: int, high: int | None = None) -> Integer:
    """The argparse type of an integer option (see Integer)."""
    return Integer(flag, low, high)


__all__ = [
    "EXIT_USAGE",
    "KEPT",
    "NOT_KEPT",
    "NO_NUMBER",
    "Parser",
    "add_options",
    "check_options",
    "config_from",
    "flag_of",
    "given",
    "integer",
    "number",
    "option",
]
