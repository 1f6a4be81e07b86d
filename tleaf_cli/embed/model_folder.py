"""A model folder's files, read and checked: `config.json` and `weights.pt`.

A model folder (docs/design.md) holds `config.json` (kind, settings, vocabulary, ...) and
`weights.pt` (a state dict, read with `torch.load(weights_only=True)`). A folder that was damaged,
truncated, hand-edited or mixed with another model's files gives an InputError that names the
file and what it should hold, never the error of the JSON reader, pickle or torch underneath:
those name neither the folder nor the fix, and torch's even advises loading with
`weights_only=False`, which would run code from the file.

Torch only (no torch_geometric): the action recognizer's folders are read here too.
"""

from __future__ import annotations

import json
import types
import typing
from dataclasses import fields
from pathlib import Path
from typing import Any

import torch

from tleaf_cli.arguments import given
from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.settings import check_values

CONFIG = "config.json"
WEIGHTS = "weights.pt"


def read_model_config(model_dir: Path, kind: str) -> dict:
    """A model directory's config.json, a JSON object of `kind` (InputError otherwise)."""
    path = Path(model_dir) / CONFIG
    if not path.is_file():
        what = "no such folder" if not Path(model_dir).is_dir() else f"no {CONFIG} in it"
        raise InputError(f"{model_dir}: not a tleaf model directory ({what})")
    try:
        config = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"{path}: cannot be read ({e})") from None
    except ValueError as e:  # json.JSONDecodeError: truncated or not JSON
        raise InputError(f"{path}: not valid JSON ({e}); expected a {kind}'s config") from None
    if not isinstance(config, dict):
        raise InputError(
            f"{path}: expected a JSON object (a {kind}'s config), found {json_kind(config)}"
        )
    if config.get("kind") != kind:
        raise InputError(f"{model_dir}: a {config.get('kind')!r} model, expected {kind!r}")
    return config


def load_weights(model: torch.nn.Module, model_dir: Path, kind: str) -> None:
    """`model_dir`/weights.pt into `model`: InputError where the file is missing, is not a state
    dict torch can read without running code, or holds another model's weights."""
    path = model_dir / WEIGHTS
    if not path.is_file():
        raise InputError(f"{path}: missing; a {kind} folder holds its trained weights there")
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as e:
        raise InputError(
            f"{path}: not a weights file that tleaf wrote ({_cause(e)}); train the {kind} "
            "again or restore the folder"
        ) from None
    if not isinstance(state, dict) or not all(isinstance(t, torch.Tensor) for t in state.values()):
        raise InputError(f"{path}: expected a state dict (names to tensors), found {given(state)}")
    try:
        model.load_state_dict(state)
    except RuntimeError as e:  # missing / unexpected keys, size mismatches
        raise InputError(
            f"{path}: the weights of another model than {CONFIG} describes ({_cause(e)})"
        ) from None


def settings_of(cls: type, config: dict, where: Path) -> Any:
    """The settings dataclass `cls` from config's "settings", its fields' types and values
    checked (InputError naming `where`)."""
    values = config_field(config, "settings", dict, where, "the training settings")
    try:
        settings = cls(**values)
    except TypeError as e:  # a field this tleaf does not know
        raise InputError(f"{where}: 'settings' are not {cls.__name__}'s ({e})") from None
    check_types(settings, where)
    return settings


def check_types(settings: object, where: Path) -> None:
    """InputError unless every field of the settings dataclass has its annotated type (JSON
    ints pass for floats) and a value within its choices and bounds."""
    hints = typing.get_type_hints(type(settings))
    for f in fields(settings):  # type: ignore[arg-type]
        value = getattr(settings, f.name)
        if not _is_instance(value, hints[f.name]):
            raise InputError(
                f"{where}: setting {f.name!r} must be {_type_name(hints[f.name])}, not "
                f"{given(value)}"
            )
    try:
        check_values(settings)
    except SettingError as e:
        raise InputError(f"{where}: {e}") from None


def _is_instance(value: Any, hint: Any) -> bool:
    if isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union:
        return any(_is_instance(value, h) for h in typing.get_args(hint))
    if hint is type(None):
        return value is None
    if hint is float:
        return isinstance(value, int | float) and not isinstance(value, bool)
    if hint is int:
        return isinstance(value, int) and not isinstance(value, bool)
    return isinstance(value, typing.get_origin(hint) or hint)


def _type_name(hint: Any) -> str:
    """A type as JSON calls it: "an integer", "a string or null", ..."""
    if isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union:
        return " or ".join(_type_name(h) for h in typing.get_args(hint))
    names = {dict: "an object", list: "a list", str: "a string", bool: "true or false"}
    names.update({int: "an integer", float: "a number", type(None): "null"})
    return names.get(hint, getattr(hint, "__name__", str(hint)))


def config_field(config: dict, name: str, kind: type, where: Path, what: str) -> Any:
    """config[name], which must be a `kind` (ints pass for float): InputError otherwise."""
    if name not in config:
        raise InputError(f"{where}: no {name!r} ({what})")
    value = config[name]
    if not _is_instance(value, kind):
        raise InputError(
            f"{where}: {name!r} ({what}) must be {_type_name(kind)}, not {json_kind(value)}"
        )
    return value


def json_kind(value: Any) -> str:
    """How JSON would call a value: 'a list', 'a string "x"', ..."""
    names = {dict: "an object", list: "a list", str: "a string", bool: "a boolean"}
    names.update({int: "a number", float: "a number", type(None): "null"})
    name = names.get(type(value), type(value).__name__)
    return f"{name} {value!r}" if isinstance(value, str | int | float) else name


def _cause(e: BaseException) -> str:
    """The first line of a library's error, without torch's advice to load unsafely."""
    lines = [line.strip() for line in str(e).splitlines() if line.strip()]
    lines = [line for line in lines if "weights_only" not in line and "Weights only" not in line]
    lines = [line for line in lines if "can still be loaded" not in line]
    for line in lines:  # load_state_dict: the first line names the class, the next the fault
        if not line.startswith("Error(s) in loading state_dict"):
            return line.rstrip(".")
    return type(e).__name__
