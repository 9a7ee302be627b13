"""Overrides: change a model's values by path without editing its file —
`joints.slider.spring.stiffness = 2e4`, `simulation.t_end = 5`, `beams.blade.section.ea = 3e8`.

A path is dot-separated: a top-level key, then for a list of items an item's *name* (or its
index), then keys inside it. Keys missing on the way are created (`joints.pin.spring.damping`
on a joint without a spring gives it one); the result is validated as a model file is, so a
wrong key or value is reported with the item it belongs to.
"""

from __future__ import annotations

import copy
import re
from collections.abc import Mapping
from typing import Any

import yaml

from . import _core

#: The word for one item of each list, for messages.
SINGULAR = {
    "nodes": "node",
    "bodies": "body",
    "beams": "beam",
    "joints": "joint",
    "loads": "load",
    "sensors": "sensor",
    "patterns": "pattern",
    "initial_spins": "initial spin",
}


class _Yaml12Loader(yaml.SafeLoader):
    """PyYAML with YAML 1.2's numbers: `2e4` and `1e-3` are floats (YAML 1.1 wants `2.0e+4`),
    as in model files (read by the Rust core)."""


_Yaml12Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?$|^[-+]?\.(?:inf|Inf|INF)$|^\.(?:nan|NaN|NAN)$"),
    list("-+0123456789."),
)


def parse_value(text: str) -> Any:
    """A value written on the command line, read as YAML 1.2: `2e4` → 20000.0, `true`,
    `[0, 0, 1]`, `{stiffness: 1e4}`, `0.3*t` → the string (an expression)."""
    try:
        value = yaml.load(text, Loader=_Yaml12Loader)
    except yaml.YAMLError:
        return text
    if isinstance(value, float) and re.fullmatch(r"[-+]?\d+", text.strip()):
        return int(text)
    return value


def parse_assignment(text: str) -> tuple[str, Any]:
    """`path=value` → (path, parsed value)."""
    path, sep, value = text.partition("=")
    if not sep or not path.strip():
        raise _core.ModelError(f"--set `{text}`: write PATH=VALUE, e.g. --set simulation.t_end=5")
    return path.strip(), parse_value(value.strip())


def apply(data: dict, overrides: Mapping[str, Any]) -> dict:
    """A copy of the model data `data` with each `path: value` of `overrides` set."""
    out = copy.deepcopy(data)
    for path, value in overrides.items():
        _set(out, path, copy.deepcopy(value))
    return out


def _set(data: dict, path: str, value):
    keys = path.split(".")
    if not all(keys):
        raise _core.ModelError(f"--set {path}: a path is keys joined by single dots")
    node, trail = data, []
    for key in keys[:-1]:
        node = _child(node, key, path, trail)
        trail.append(key)
    last = keys[-1]
    if isinstance(node, list):
        node[_index(node, last, path, trail)] = value
    elif isinstance(node, dict):
        node[last] = value
    else:
        raise _core.ModelError(
            f"--set {path}: `{'.'.join(trail)}` is a value ({node!r}), not a group of keys"
        )


def _child(node, key: str, path: str, trail: list[str]):
    """The entry `key` of a mapping (created empty if missing) or the item named `key` of a
    list."""
    if isinstance(node, list):
        return node[_index(node, key, path, trail)]
    if not isinstance(node, dict):
        raise _core.ModelError(
            f"--set {path}: `{'.'.join(trail)}` is a value ({node!r}), not a group of keys"
        )
    if node.get(key) is None:
        # A list of items is never created here: a missing one is an unknown top-level key.
        node[key] = {}
    return node[key]


def _index(items: list, key: str, path: str, trail: list[str]) -> int:
    """The position of the item named `key` (or at index `key`) in a list of items."""
    names = [item.get("name") if isinstance(item, dict) else None for item in items]
    if key in names:
        return names.index(key)
    if re.fullmatch(r"\d+", key) and int(key) < len(items):
        return int(key)
    what = SINGULAR.get(trail[-1] if trail else "", "item")
    known = ", ".join(n for n in names if n) or "none"
    raise _core.ModelError(
        f"--set {path}: no {what} named `{key}` in `{'.'.join(trail)}` (there are: {known})"
    )
