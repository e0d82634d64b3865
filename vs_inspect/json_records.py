"""Typed records to JSON values and back (result.json's "cues" is written and read with these).

Every record is a frozen dataclass of plain values (numbers, strings, tuples, dicts of those,
other records). A field that is None is left out of the JSON, unless its metadata says "null"
(then it is written as null); a field marked "flat" is a record whose keys go into its owner's.
"""

from __future__ import annotations

import dataclasses
import functools
import types
import typing
from typing import Any

NULL = {"null": True}  # field metadata: written as null when None
FLAT = {"flat": True}  # field metadata: a record whose keys go into its owner's


def to_json(obj: Any) -> Any:
    """A record (or a value holding records) as JSON values."""
    if dataclasses.is_dataclass(obj):
        out: dict[str, Any] = {}
        for f in dataclasses.fields(obj):
            v = getattr(obj, f.name)
            if v is None and not f.metadata.get("null"):
                continue
            if f.metadata.get("flat"):
                out.update(to_json(v))
            else:
                out[f.name] = to_json(v)
        return out
    if isinstance(obj, dict):
        return {k: to_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_json(v) for v in obj]
    return obj


@functools.cache
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def from_json(tp: Any, data: Any) -> Any:
    """The value of type tp (a record, a container of records or a plain type) from to_json's output."""
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        return None if data is None else from_json(args[0], data)
    if dataclasses.is_dataclass(tp):
        hints = _hints(tp)
        kwargs = {}
        for f in dataclasses.fields(tp):
            if f.metadata.get("flat"):  # left out (None) when none of its keys is there
                inner = [a for a in typing.get_args(hints[f.name]) if a is not type(None)] or [hints[f.name]]
                kwargs[f.name] = from_json(inner[0], data) if _has_any(data, inner[0]) else None
            elif f.name in data:
                kwargs[f.name] = from_json(hints[f.name], data[f.name])
        return tp(**kwargs)
    if origin is dict:
        _, vt = typing.get_args(tp)
        return {k: from_json(vt, v) for k, v in data.items()}
    if origin is tuple:
        args = typing.get_args(tp)
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(from_json(args[0], v) for v in data)
        return tuple(from_json(a, v) for a, v in zip(args, data))
    if tp is float and data is not None:
        return float(data)
    return data


def _has_any(data: dict, cls: type) -> bool:
    """Whether data holds any key of record cls."""
    return any(f.name in data for f in dataclasses.fields(cls))
