"""The one root config of a run: Stage 0, Stage 1+2 and recording settings in one record.

RunConfig.to_dict()/from_dict() give the JSON that `sync` saves as OUT/config.json and reads back
with --config (unknown keys and wrong types are errors naming the key). Every field can be set by
its dotted path (`--set sync.landscape.range_s=5`, with_settings) and a few named presets set
several at once (`--preset fast`, PRESETS). The command-line options are generated from the same
dataclasses: a field whose metadata names a "flag" becomes that option, with the field's one-line
docstring as its help, so there is no second list of settings to keep in step.

Field metadata understood by add_config_options:
  flag     the option, e.g. "--energy"
  choices  allowed values; help  replaces the docstring; metavar, nargs  as in argparse
  negate   True: a boolean field that the flag switches off (store_const False)
  enable   True: a boolean field that the flag switches on (store_const True)
  append   True: a repeatable option (the values arrive as a list)
  apply    f(value, owner) -> new owner: how the option's value changes the field's dataclass
           (for options that set several fields, or parse a text); default: set the field
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import functools
import inspect
import os
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..cues.config import CueConfig
from ..engine import EngineConfig
from ..errors import InputError
from ..io.atomic import write_json_atomic
from ..io.result import read_json_file
from ..analysis.record_options import RecordOptions
from ..sync.config import SyncConfig


@dataclass(frozen=True)
class RunConfig:
    """Everything a run can be told, as one tree of frozen dataclasses."""

    cues: CueConfig = field(default_factory=CueConfig,
                            metadata={"group": "cue extraction (Stage 0)"})
    """Stage 0: moving regions, tracks, cross-view pairs, cameras."""
    sync: SyncConfig = field(default_factory=SyncConfig,
                             metadata={"group": "synchronization (Stage 1 and 2)"})
    """Stage 1 (pair landscapes and decisions) and Stage 2 (global solve)."""
    record: RecordOptions = field(default_factory=RecordOptions)
    """What the rerun recording keeps (when a recording is written)."""
    engine: EngineConfig = field(default_factory=EngineConfig,
                                 metadata={"group": "engine (where Stage 0 and Stage 1 run)"})
    """Where the per-video and per-pair work runs (local or Ray); the results do not depend on it."""

    def to_dict(self) -> dict[str, Any]:
        return _to_dict(self)

    @staticmethod
    def from_dict(data: dict[str, Any]) -> RunConfig:
        """The config of a dictionary as to_dict writes it; missing keys keep their defaults.

        InputError naming the key for an unknown key or a value of the wrong type."""
        return _from_dict(RunConfig, data, "")

    def save(self, path: str | os.PathLike) -> Path:
        """Write as JSON atomically (a folder gets config.json inside)."""
        path = Path(path)
        if path.is_dir():
            path = path / "config.json"
        return write_json_atomic(self.to_dict(), path)

    @staticmethod
    def load(path: str | os.PathLike) -> RunConfig:
        """A config.json (or a run folder holding one); InputError naming the file and the key."""
        data, path = read_json_file(path, "config.json")
        try:
            return RunConfig.from_dict(data)
        except (InputError, ValueError) as exc:
            raise InputError(f"{path}: {exc}") from None


# ---- presets and dotted paths -------------------------------------------------------------------

PRESETS: dict[str, tuple[str, dict[str, Any]]] = {
    "estimated": ("cameras estimated from the videos, each camera model tried while a video is untrusted "
                  "(the usual settings)", {}),
    "calibrated": ("cameras from --calib, which the run then needs (it is refused without one rather than "
                   "estimating them); otherwise the usual settings", {}),
    "fast": ("quicker, less thorough: 480 px working frames, 800 tracks and 8 keyframes per video, SIFT's "
             "camera model only on fewer frames, no heads",
             {"cues.max_side": 480, "cues.max_tracks": 800, "cues.keyframes": 8, "cues.camera.features": "sift",
              "cues.camera.static_frames": 5, "cues.camera.moving_frames": 15, "cues.heads": False}),
    "paper": ("the VisualSync paper's energy and solve where vs_inspect differs: the plain mean of the "
              "Sampson errors, no drift, no worn-camera sightings",
              {"sync.landscape.loss": "mean", "sync.drift.enabled": False, "sync.sightings.enabled": False,
               "cues.heads": False}),
}


def settings(cls: type = None, prefix: str = "") -> dict[str, tuple[type, str]]:
    """{dotted path: (its class, its field name)} of every setting of RunConfig (or of cls)."""
    cls = cls or RunConfig
    out: dict[str, tuple[type, str]] = {}
    for f in dataclasses.fields(cls):
        tp = _hints(cls)[f.name]
        path = f"{prefix}{f.name}"
        if dataclasses.is_dataclass(tp):
            out.update(settings(tp, path + "."))
        else:
            out[path] = (cls, f.name)
    return out


def _parse_value(text: str) -> Any:
    """A --set value: JSON when it reads as JSON (numbers, true/false, null, lists, objects), yes/no
    and on/off as booleans, else the text itself."""
    import json

    low = text.strip().lower()
    if low in ("yes", "on"):
        return True
    if low in ("no", "off"):
        return False
    try:
        return json.loads(text)
    except ValueError:
        return text


def with_settings(base: RunConfig, items: dict[str, Any], source: str = "--set") -> RunConfig:
    """base with each dotted path of items set to its value, checked as a config file's would be;
    InputError naming an unknown path (and the known ones nearby) or a wrong value."""
    known = settings()
    data = base.to_dict()
    for path, value in items.items():
        if path not in known:
            section = path.rsplit(".", 1)[0] if "." in path else ""
            near = sorted(p for p in known if p.startswith(section + ".")) if section else []
            raise InputError(f"{source}: unknown setting {path!r}" + (
                f" (known in {section}: {', '.join(p.removeprefix(section + '.') for p in near)})" if near else
                f" (known: {', '.join(sorted({p.split('.')[0] for p in known}))} and their fields; "
                "`vs-inspect sync --help` lists them)"))
        owner = data
        *head, last = path.split(".")
        for key in head:
            owner = owner[key]
        owner[last] = value
    try:
        return RunConfig.from_dict(data)
    except InputError as exc:
        raise InputError(f"{source}: {exc}") from None


def parse_set(items: list[str]) -> dict[str, Any]:
    """--set PATH=VALUE items as {path: value}; InputError for an item without '='."""
    out: dict[str, Any] = {}
    for item in items:
        path, eq, value = item.partition("=")
        if not eq or not path.strip():
            raise InputError(f"--set must be PATH=VALUE (e.g. sync.landscape.range_s=5), got {item!r}")
        out[path.strip()] = _parse_value(value)
    return out


def preset(name: str) -> dict[str, Any]:
    """The settings of a preset by name; InputError naming the presets for another name."""
    if name not in PRESETS:
        raise InputError(f"--preset {name!r}: unknown; use {', '.join(PRESETS)}")
    return dict(PRESETS[name][1])


# ---- dict <-> dataclasses, checked -------------------------------------------------------------


def _is_config(x: Any) -> bool:
    return dataclasses.is_dataclass(x)


def _to_dict(obj: Any) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for f in dataclasses.fields(obj):
        v = getattr(obj, f.name)
        out[f.name] = _to_dict(v) if _is_config(v) else (dict(v) if isinstance(v, dict) else v)
    return out


@functools.cache
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def _check_value(tp: Any, v: Any, key: str) -> Any:
    """v as a value of type tp (ints are accepted for floats); InputError naming key otherwise."""
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = typing.get_args(tp)
        if v is None and type(None) in args:
            return None
        errors = []
        for a in args:
            if a is type(None):
                continue
            try:
                return _check_value(a, v, key)
            except InputError as exc:
                errors.append(exc)
        raise errors[0]
    if origin is dict:
        kt, vt = typing.get_args(tp)
        if not isinstance(v, dict):
            raise InputError(f"config key {key!r} must be an object, got {type(v).__name__}")
        return {_check_value(kt, k, f"{key}.{k}"): _check_value(vt, x, f"{key}.{k}") for k, x in v.items()}
    if origin is tuple:
        args = typing.get_args(tp)
        if not isinstance(v, (list, tuple)) or len(v) != len(args):
            raise InputError(f"config key {key!r} must be a list of {len(args)} values, got {v!r}")
        return tuple(_check_value(t, x, f"{key}[{i}]") for i, (t, x) in enumerate(zip(args, v)))
    if dataclasses.is_dataclass(tp):
        return _from_dict(tp, v, key)
    if tp is float:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise InputError(f"config key {key!r} must be a number, got {type(v).__name__} {v!r}")
        return float(v)
    if tp is int:
        if isinstance(v, bool) or not isinstance(v, int):
            raise InputError(f"config key {key!r} must be an integer, got {type(v).__name__} {v!r}")
        return v
    if tp in (bool, str):
        if not isinstance(v, tp):
            raise InputError(f"config key {key!r} must be {'true or false' if tp is bool else 'a string'}, "
                             f"got {type(v).__name__} {v!r}")
        return v
    raise TypeError(f"config field {key!r} has a type the config reader does not know: {tp}")


def _from_dict(cls: type, data: Any, prefix: str) -> Any:
    where = prefix or "config"
    if not isinstance(data, dict):
        raise InputError(f"{where} must be an object, got {type(data).__name__}")
    hints = _hints(cls)
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = [k for k in data if k not in names]
    if unknown:
        key = f"{prefix}.{unknown[0]}" if prefix else str(unknown[0])
        raise InputError(f"unknown config key {key!r} "
                         f"(known in {where}: {', '.join(sorted(names))})")
    kwargs = {k: _check_value(hints[k], v, f"{prefix}.{k}" if prefix else k) for k, v in data.items()}
    try:
        return cls(**kwargs)
    except ValueError as exc:
        raise InputError(f"{where}: {exc}") from None


# ---- the command line, generated from the fields -----------------------------------------------


@functools.cache
def field_doc(cls: type, name: str) -> str:
    """The docstring under a dataclass field (the string literal that follows it)."""
    body = ast.parse(inspect.getsource(cls)).body[0].body
    for i, node in enumerate(body):
        if isinstance(node, ast.AnnAssign) and getattr(node.target, "id", None) == name:
            nxt = body[i + 1] if i + 1 < len(body) else None
            if isinstance(nxt, ast.Expr) and isinstance(nxt.value, ast.Constant):
                return str(nxt.value.value)
    return ""


def _flag_fields(cls: type, path: tuple[str, ...] = ()):
    """(path of the owning dataclass, its class, the field) for every field that names a flag."""
    for f in dataclasses.fields(cls):
        tp = _hints(cls)[f.name]
        if "flag" in f.metadata:
            yield path, cls, f
        elif dataclasses.is_dataclass(tp):
            yield from _flag_fields(tp, path + (f.name,))


def _dest(path: tuple[str, ...], name: str) -> str:
    return "config:" + ".".join(path + (name,))


def _scalar_type(tp: Any) -> Any:
    args = [a for a in typing.get_args(tp) if a is not type(None)]
    return args[0] if typing.get_origin(tp) in (typing.Union, types.UnionType) and len(args) == 1 else tp


def add_config_options(parser: argparse.ArgumentParser, sections: tuple[str, ...],
                       group: Any = None) -> None:
    """One option per flagged field of RunConfig's sections (e.g. ("sync", "cues")), help = the
    field's docstring. The options default to "not given", so that config_from_args can tell a
    value on the command line from one in a --config file. group: add them to this argument
    group (default: one group per section)."""
    for section in sections:
        top = next(f for f in dataclasses.fields(RunConfig) if f.name == section)
        g = group or parser.add_argument_group(top.metadata.get("group", section))
        default_root = getattr(RunConfig(), section)
        for path, cls, f in _flag_fields(_hints(RunConfig)[section], (section,)):
            md = f.metadata
            owner = functools.reduce(getattr, path[1:], default_root)
            default = getattr(owner, f.name)
            # a docstring's "None = X" (the config file's null) reads "default: X" on the command line
            help_text = (md.get("help") or field_doc(cls, f.name)).replace("None = ", "default: ")
            kw: dict[str, Any] = {"dest": _dest(path, f.name), "default": argparse.SUPPRESS}
            if md.get("negate"):
                kw.update(action="store_const", const=False)
            elif md.get("enable"):
                kw.update(action="store_const", const=True)
            elif md.get("append"):
                kw.update(action="append", metavar=md.get("metavar"))
            else:
                tp = md.get("type") or _scalar_type(_hints(cls)[f.name])
                kw.update(type=tp)
                if "choices" in md:
                    kw["choices"] = tuple(md["choices"])
                if "metavar" in md or "choices" not in md:
                    kw["metavar"] = md.get("metavar", md["flag"].lstrip("-").upper().replace("-", "_"))
                if "nargs" in md:
                    kw["nargs"] = md["nargs"]
                shown = md.get("default_text", default)
                # once, and only a real value: a docstring that explains its own default (or
                # what None means) is not followed by "(default: None)"
                if not isinstance(shown, dict) and shown is not None \
                        and "default" not in help_text.lower():
                    help_text += f" (default: {shown})"
            g.add_argument(md["flag"], help=help_text.replace("%", "%%"), **kw)


def config_from_args(args: argparse.Namespace, base: RunConfig = RunConfig()) -> RunConfig:
    """base (the --config file or the defaults) with every option given on the command line
    applied on top: the command line wins."""
    given = {k.removeprefix("config:"): v for k, v in vars(args).items() if k.startswith("config:")}
    if not given:
        return base
    by_path = {".".join(p + (f.name,)): (p, f) for p, _, f in _flag_fields(RunConfig)}
    out = base
    for key, value in given.items():
        path, f = by_path[key]
        owner = functools.reduce(getattr, path, out)
        apply = f.metadata.get("apply")
        try:
            new_owner = apply(value, owner) if apply else dataclasses.replace(owner, **{f.name: value})
        except ValueError as exc:
            flag = f.metadata["flag"]
            raise InputError(str(exc) if flag in str(exc) else f"{flag}: {exc}") from None
        out = _replace_at(out, path, new_owner)
    return out


def _replace_at(root: Any, path: tuple[str, ...], value: Any) -> Any:
    if not path:
        return value
    head, rest = path[0], path[1:]
    return dataclasses.replace(root, **{head: _replace_at(getattr(root, head), rest, value)})
