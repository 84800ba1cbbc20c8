"""Typed results to JSON and back: the journal and results.json are renderings of frozen dataclasses.

``to_record`` turns a dataclass (nested dataclasses, tuples, dicts) into JSON-ready data; ``from_record``
rebuilds it from the class's own type hints, so a journal line read back is the same typed value that was
written (floats round-trip exactly through ``repr``). Non-finite floats become None: JSON has no NaN. A class
whose fields are not its record's keys (outputs by the FMU's names) gives its own record: an ``as_record``
method and a ``read_record`` class method.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from functools import lru_cache
from typing import Any, Union


def to_record(value: Any) -> Any:
    if hasattr(value, "as_record") and not isinstance(value, type):
        return to_record(value.as_record())
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: to_record(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, dict):
        return {str(k): to_record(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_record(v) for v in value]
    if isinstance(value, bool) or value is None or isinstance(value, (int, str)):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if hasattr(value, "item"):  # numpy scalars
        return to_record(value.item())
    if hasattr(value, "tolist"):  # numpy arrays
        return to_record(value.tolist())
    raise TypeError(f"cannot record a {type(value).__name__}: {value!r}")


@lru_cache(maxsize=None)
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def from_record(cls: Any, data: Any) -> Any:
    """``data`` (as ``to_record`` wrote it) as an instance of the type ``cls``."""
    origin = typing.get_origin(cls)
    if cls is Any:
        return data
    if origin in (Union, types.UnionType):
        arguments = typing.get_args(cls)
        if data is None:
            if type(None) in arguments:
                return None
            raise ValueError(f"expected {cls}, got None")
        for argument in arguments:
            if argument is type(None):
                continue
            try:
                return from_record(argument, data)
            except (TypeError, ValueError, KeyError):
                continue
        raise ValueError(f"{data!r} is none of {cls}")
    if isinstance(cls, type) and hasattr(cls, "read_record"):
        return cls.read_record(data)
    if isinstance(cls, type) and dataclasses.is_dataclass(cls):
        if not isinstance(data, dict):
            raise ValueError(f"expected an object for {cls.__name__}, got {type(data).__name__}")
        hints = _hints(cls)
        values = {}
        for f in dataclasses.fields(cls):
            if f.name in data:
                values[f.name] = from_record(hints[f.name], data[f.name])
            elif f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                raise KeyError(f"{cls.__name__}: {f.name} is missing")
        return cls(**values)
    if origin is tuple:
        arguments = typing.get_args(cls)
        if not isinstance(data, list):
            raise ValueError(f"expected a list, got {type(data).__name__}")
        if len(arguments) == 2 and arguments[1] is Ellipsis:
            return tuple(from_record(arguments[0], v) for v in data)
        if len(arguments) != len(data):
            raise ValueError(f"expected {len(arguments)} values, got {len(data)}")
        return tuple(from_record(a, v) for a, v in zip(arguments, data))
    if origin is list:
        (argument,) = typing.get_args(cls) or (Any,)
        return [from_record(argument, v) for v in data]
    if origin is dict:
        key_type, value_type = typing.get_args(cls) or (Any, Any)
        return {from_record(key_type, k): from_record(value_type, v) for k, v in data.items()}
    if cls is float:
        if data is None:
            return math.nan
        if isinstance(data, bool) or not isinstance(data, (int, float)):
            raise ValueError(f"expected a number, got {data!r}")
        return float(data)
    if cls is int:
        if isinstance(data, bool) or not isinstance(data, int):
            raise ValueError(f"expected an integer, got {data!r}")
        return data
    if cls is bool:
        if not isinstance(data, bool):
            raise ValueError(f"expected true or false, got {data!r}")
        return data
    if cls is str:
        if not isinstance(data, str):
            raise ValueError(f"expected a string, got {data!r}")
        return data
    if cls is type(None):
        if data is not None:
            raise ValueError(f"expected null, got {data!r}")
        return None
    raise TypeError(f"cannot read a {cls}")


__all__ = ["from_record", "to_record"]
