"""The study file: ``study.toml``, every option that shaped a run, to run it again, diff it and share it.

Every run writes one into its report folder; ``run.py --study FILE`` runs it, options on the command line
overriding the file's. The keys are the command-line options without their dashes, in one section per config
(``[case]``, one per step with options, ``[run]``, ``[cluster]``), derived from the configs' ``option`` fields:
there is no second list of names. Options that change no number (the executor, the workers, the scheduler, the
cluster) are written as comments; options of one invocation (``--out``, ``--resume``) are not written.
``[recorded]`` holds what the file was written against (the content hashes of the material table, the FMU and
the other files it names): a file whose content changed is refused, another FMU build is named in a note.

Relative paths in the file are relative to the file's folder: a file inside the folder the run was started from
(the project) is written so, and the project can be moved or sent whole; a file elsewhere is written by its
absolute path.

Why a template and not a TOML writer: the file carries comments (each option's meaning and default, the
options left at the scene's or the model's value), which the TOML writers drop. tomllib reads it back, and the
tests read back every file they write.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import math
import os
import re
import textwrap
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from builder.rendering import environment

from .options import NO_NUMBER, NOT_KEPT, flag_of

STUDY_FILE = "study.toml"
FORMAT = "lattice-study/1"
RECORDED = "recorded"


def sections() -> list[tuple[str, type]]:
    """(section, config type) of every config with options, in the order the CLI shows them."""
    from .cluster import ClusterConfig
    from .runner import RunConfig
    from .steps import STEPS
    from .study import CaseConfig

    found: list[tuple[str, type]] = [("case", CaseConfig)]
    found += [(step.name, step.Config) for step in STEPS if dataclasses.fields(step.Config)]
    found.append(("run", RunConfig))
    found.append(("cluster", ClusterConfig))
    return found


def _options(config_type: type) -> list[tuple[str, dataclasses.Field, dict]]:
    """(key, field, option metadata) of each option of ``config_type``: the key is the flag without dashes."""
    return [
        (flag_of(config_type, f.name)[2:], f, f.metadata["option"])
        for f in dataclasses.fields(config_type)
        if "option" in f.metadata
    ]


class StudyFileError(ValueError):
    """A study file that cannot be run as it is (one line: the file, the line, the key, the allowed values)."""


# ---------------------------------------------------------------------------------------------- writing
def _toml(value: Any) -> str:
    """A TOML value (strings as JSON writes them: its escapes are TOML's basic-string escapes)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            return {math.inf: "inf", -math.inf: "-inf"}.get(value, "nan")
        text = repr(value)
        return text if any(c in text for c in ".en") else text + ".0"
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    raise TypeError(f"no TOML value for {value!r}")


def _file_value(value: Any, meta: dict, folder: Path) -> Any:
    """What the file holds for an option's value: a flag as "given"; a path relative to the file's folder when
    both are in the folder the run was started from (a project folder moved or sent whole), else absolute."""
    if meta["action"] == "store_false":
        return not value
    if meta["path"] and isinstance(value, str) and Path(value).exists():
        path, here = Path(value).resolve(), Path.cwd().resolve()
        if path.is_relative_to(here) and folder.resolve().is_relative_to(here):
            return os.path.relpath(path, folder.resolve())
        return str(path)
    return value


@dataclass(frozen=True)
class Line:
    key: str
    value: str | None  # the TOML value; None: left to its default (written as a comment)
    comment: str  # comment lines, each starting with "#"
    active: bool = True


def _comment(text: str) -> str:
    return "\n".join(textwrap.wrap(text, 110, initial_indent="# ", subsequent_indent="#   "))


def study_lines(configs: dict[type, Any], folder: Path) -> list[tuple[str, str, list[Line]]]:
    """(section, its comment, its lines) of the study file for ``configs`` (config type -> config)."""
    out = []
    for section, config_type in sections():
        config = configs.get(config_type) or config_type()
        lines = []
        for key, field, meta in _options(config_type):
            if meta["study"] == NOT_KEPT:
                continue
            value = getattr(config, field.name)
            help_text = meta["help"]
            if value is None or value == () or value == []:
                shown = meta["show_default"] if meta["show_default"] is not None else "none"
                lines.append(
                    Line(key, None, _comment(f"{key}: {help_text}; left to its default: {shown}"), active=False)
                )
                continue
            text = _toml(_file_value(value, meta, folder))
            if meta["study"] == NO_NUMBER:
                lines.append(
                    Line(
                        key,
                        text,
                        _comment(f"{key}: {help_text}; changes no number (give it on the command line)"),
                        active=False,
                    )
                )
            else:
                lines.append(Line(key, text, _comment(f"{key}: {help_text}")))
        comment = {
            "run": "how the run ran: none of it changes a number but time-limit (which evaluations fail)",
            "cluster": "where Dask's workers ran (with --executor dask): none of it changes a number",
        }.get(section, "")
        out.append((section, comment, lines))
    return out


TEMPLATE = """\
# A study of the material order of a mass-spring lattice ({{ format }}).
# Run it again:   python orchestrator/run.py --study {{ name }} --out DIR [options that override this file's]
# Keys are the command-line options without their dashes (python orchestrator/run.py --help says what each
# means); a key left out takes its default, a flag's key is true when the flag is given. Relative paths are
# relative to this file's folder.
{% for section, comment, lines in sections %}

[{{ section }}]
{% if comment %}# {{ comment }}
{% endif %}
{% for line in lines %}
{{ line.comment }}
{% if line.active %}
{{ line.key }} = {{ line.value }}
{% elif line.value is not none %}
# {{ line.key }} = {{ line.value }}
{% endif %}
{% endfor %}
{% endfor %}

[{{ recorded }}]
# What this file was written against: a material table, scene file or start file whose content changed is
# refused; another build of the FMU (another platform or compiler) is named in a note, its numbers may differ
# in the last digits.
materials-sha256 = {{ materials_sha256 }}
fmu-sha256 = {{ fmu_sha256 }}
{% for key, value in file_hashes %}
{{ key }} = {{ value }}
{% endfor %}
"""


FILE_CHECKED = ("materials", "fmu")  # path options whose content [recorded] checks by its own hash (above)


def _file_sha256(path: str | Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def file_hashes(configs: dict[type, Any]) -> list[tuple[str, str]]:
    """("<key>-sha256", TOML value) of each other file a path option names (a scene file, a start file): a
    study file run on another file's content is refused."""
    found = []
    for _, config_type in sections():
        config = configs.get(config_type) or config_type()
        for key, field, meta in _options(config_type):
            value = getattr(config, field.name)
            if (
                meta["path"]
                and meta["study"] != NOT_KEPT
                and key not in FILE_CHECKED
                and isinstance(value, str)
                and Path(value).is_file()
            ):
                found.append((f"{key}-sha256", _toml(_file_sha256(value))))
    return found


def render_study_file(configs: dict[type, Any], folder: Path, materials_sha256: str, fmu_sha256: str) -> str:
    return (
        environment()
        .from_string(TEMPLATE)
        .render(
            format=FORMAT,
            name=STUDY_FILE,
            sections=study_lines(configs, folder),
            recorded=RECORDED,
            materials_sha256=_toml(materials_sha256),
            fmu_sha256=_toml(fmu_sha256),
            file_hashes=file_hashes(configs),
        )
    )


def write_study_file(folder: Path, configs: dict[type, Any], materials_sha256: str, fmu_sha256: str) -> Path:
    """``folder/study.toml`` for a run of ``configs``; paths in it are relative to ``folder``'s final name
    (a run writes into OUT.partial, a sibling of OUT)."""
    folder = Path(folder)
    final = folder.with_name(folder.name[: -len(".partial")]) if folder.name.endswith(".partial") else folder
    path = folder / STUDY_FILE
    path.write_text(render_study_file(configs, final, materials_sha256, fmu_sha256))
    return path


# ---------------------------------------------------------------------------------------------- reading
@dataclass(frozen=True)
class StudyFile:
    """A study file read and checked: the option values it sets (argparse destinations), what it recorded."""

    path: Path
    values: dict[str, Any]  # "ConfigType.field" -> value, as argparse would have parsed it
    materials_sha256: str | None
    fmu_sha256: str | None

    def apply(self, namespace: argparse.Namespace) -> argparse.Namespace:
        """``namespace`` with this file's values where the command line gave none (the command line wins)."""
        for dest, value in self.values.items():
            if not hasattr(namespace, dest):
                setattr(namespace, dest, value)
        return namespace

    def check_materials(self, table) -> None:
        """Refuses a material table whose content is not the one the file was written against."""
        if self.materials_sha256 is not None and table.sha256() != self.materials_sha256:
            raise StudyFileError(
                f"{self.path}:{_line_of(self.path.read_text(), RECORDED, 'materials-sha256')}: [{RECORDED}] "
                f"materials-sha256: the material table this run reads has content {table.sha256()[:16]}..., the "
                f"study was run on {self.materials_sha256[:16]}...: give the same table (or delete this line to "
                "run the study on the new one)"
            )

    def fmu_note(self, fmu_sha256: str) -> str | None:
        if self.fmu_sha256 is None or fmu_sha256 == self.fmu_sha256:
            return None
        return (
            f"note: the FMU ({fmu_sha256[:16]}...) is another build than the one {self.path} was written "
            f"against ({self.fmu_sha256[:16]}...): its numbers may differ in the last digits"
        )


_HEADER = re.compile(r"^\s*\[\s*([A-Za-z0-9_-]+)\s*\]")
_KEY = re.compile(r"^\s*([A-Za-z0-9_\"'.-]+)\s*=")


def _line_of(text: str, section: str, key: str | None = None) -> int:
    """The line number of ``key`` in ``[section]`` (of the section's header when ``key`` is None); 1 when not
    found (a key written in an unusual TOML form)."""
    current = None
    for number, line in enumerate(text.splitlines(), start=1):
        header = _HEADER.match(line)
        if header:
            current = header.group(1)
            if key is None and current == section:
                return number
            continue
        match = _KEY.match(line)
        if key is not None and match and current == section and match.group(1).strip("\"'") == key:
            return number
    return 1


def _parse(meta: dict, key: str, value: Any) -> Any:
    """The option's value from the file's, checked as the command line checks it; ValueError says why."""
    flag = f"--{key}"
    action = meta["action"]
    if action in ("store_true", "store_false"):
        if not isinstance(value, bool):
            raise ValueError(f"must be true or false (true: the flag {flag} is given), got {_toml_or_repr(value)}")
        return (not value) if action == "store_false" else value
    if action == "append" or meta["nargs"] in ("+", "*") or isinstance(meta["nargs"], int):
        one = meta["nargs"] in ("+", "*", 1) or action == "append"  # a single value stands for a list of one
        items = value if isinstance(value, list) else [value] if one and not isinstance(value, (dict, bool)) else None
        if items is None or (meta["nargs"] == "+" and not items):
            raise ValueError(f'must be a list of values, e.g. ["a", "b"], got {_toml_or_repr(value)}')
        parsed = [_scalar(meta, flag, item) for item in items]
        return tuple(parsed) if action != "append" else parsed
    return _scalar(meta, flag, value)


def _scalar(meta: dict, flag: str, value: Any) -> Any:
    if isinstance(value, (dict, list)) or isinstance(value, bool):
        raise ValueError(f"must be a single value, got {_toml_or_repr(value)}")
    kind = meta["type"]
    if kind is not None:
        try:
            value = kind(str(value))
        except argparse.ArgumentTypeError as exc:
            raise ValueError(str(exc)) from None
    elif not isinstance(value, str):
        raise ValueError(f"must be a string, got {_toml_or_repr(value)}")
    if meta["choices"] is not None and value not in meta["choices"]:
        raise ValueError(f"allowed values are {', '.join(map(str, meta['choices']))}, got {value!r}")
    return value


def _toml_or_repr(value: Any) -> str:
    try:
        return _toml(value)
    except TypeError:
        return repr(value)


def _resolve_path(value: Any, folder: Path) -> Any:
    """A relative path in the file is relative to its folder (a name that is no file there stays a name)."""
    if isinstance(value, str) and value and not Path(value).is_absolute() and (folder / value).exists():
        return str(folder / value)
    return value


def read_study_file(path: str | os.PathLike) -> StudyFile:
    """The study file at ``path``, every key and value checked; StudyFileError names the first wrong one."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise StudyFileError(f"--study {path}: cannot read it ({exc.strerror or exc})") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise StudyFileError(f"--study {path}: not a TOML file ({exc})") from None
    known = dict(sections())
    allowed_sections = ", ".join([f"[{s}]" for s in known] + [f"[{RECORDED}]"])
    values: dict[str, Any] = {}
    recorded: dict[str, str | None] = {"materials-sha256": None, "fmu-sha256": None}
    files: dict[str, tuple[str, str]] = {}  # "<key>-sha256" -> (section, key) of the path options checked by it
    for section, config_type in known.items():
        for key, _, meta in _options(config_type):
            if meta["path"] and meta["study"] != NOT_KEPT and key not in FILE_CHECKED:
                files[f"{key}-sha256"] = (section, key)
                recorded[f"{key}-sha256"] = None
    for section, table in data.items():
        where = f"{path}:{_line_of(text, section)}"
        if not isinstance(table, dict):
            raise StudyFileError(
                f"{where}: {section}: every key belongs to a section; allowed sections: {allowed_sections}"
            )
        if section == RECORDED:
            for key, value in table.items():
                if key not in recorded or not isinstance(value, str):
                    raise StudyFileError(
                        f"{path}:{_line_of(text, section, key)}: [{RECORDED}] {key}: allowed keys "
                        f"are {', '.join(recorded)}, each a string"
                    )
                recorded[key] = value
            continue
        if section not in known:
            raise StudyFileError(f"{where}: [{section}]: not a section of a study file; allowed: {allowed_sections}")
        config_type = known[section]
        options = {key: (field, meta) for key, field, meta in _options(config_type) if meta["study"] != NOT_KEPT}
        for key, value in table.items():
            where = f"{path}:{_line_of(text, section, key)}"
            if key not in options:
                owner = next(
                    (other for other, other_type in known.items() if any(k == key for k, _, _ in _options(other_type))),
                    None,
                )
                moved = f" (an option of [{owner}])" if owner else ""
                raise StudyFileError(
                    f"{where}: [{section}] {key}: not an option of [{section}]{moved}; allowed: {', '.join(options)}"
                )
            field, meta = options[key]
            try:
                parsed = _parse(meta, key, value)
            except ValueError as exc:
                raise StudyFileError(f"{where}: [{section}] {key}: {exc}") from None
            if meta["path"]:
                parsed = _resolve_path(parsed, path.parent)
            default = field.default
            if parsed == default or (isinstance(parsed, list) and tuple(parsed) == default):
                continue  # the default: the run gets it anyway, and the option does not count as given
            values[f"{config_type.__name__}.{field.name}"] = parsed
    for hash_key, (section, key) in files.items():
        expected = recorded[hash_key]
        if expected is None or section not in data or key not in data[section]:
            continue
        named = _resolve_path(data[section][key], path.parent)
        actual = _file_sha256(named) if isinstance(named, str) and Path(named).is_file() else None
        if actual is not None and actual != expected:
            raise StudyFileError(
                f"{path}:{_line_of(text, RECORDED, hash_key)}: [{RECORDED}] {hash_key}: {named} has "
                f"changed since the study was run (sha256 {actual[:16]}..., the study's "
                f"{expected[:16]}...): give the same file (or delete this line to run the study on "
                "the new one)"
            )
    return StudyFile(path, values, recorded["materials-sha256"], recorded["fmu-sha256"])


__all__ = [
    "STUDY_FILE",
    "StudyFile",
    "StudyFileError",
    "read_study_file",
    "render_study_file",
    "sections",
    "write_study_file",
]
