"""Changing a scene file's values without editing it (``motes run --set KEY=VALUE``).

An override sets one value of the parsed TOML document before the scene is read, so
the value meets the same checks as one written in the file, and mistakes are reported
with the same key paths (``system[0].emitter[0].rate``).

A key is a dotted path: ``scene.seed``, ``camera.fov``. An array (of tables, like
``[[system]]``, or of values, like ``camera.position``) is indexed by number from 0
(``system.0.emitter.0.rate``), and an array of tables also by the ``name`` of an entry
(``system.fire.emitter.0.rate``, ``body.flag.density``). A part holding a dot is quoted
as in TOML (``system."my.fire".capacity``). Tables the file leaves out are made
(``render.exposure`` in a file without ``[render]``); a key the table does not have is
reported by the reader, as in a file, with a guess.
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping

import numpy as np

from .schema import SceneError, _kind, close_matches


def parse_value(text: str):
    """``text`` as a TOML value (``7``, ``0.5``, ``"fire"``, ``[1, 2, 3]``, ``true``);
    text that is not one is taken as a string (``--set scene.name=fire``)."""
    if "\n" in text or "\r" in text:
        return text
    try:
        parsed = tomllib.loads(f"value = {text}")
    except tomllib.TOMLDecodeError:
        return text
    return parsed["value"] if list(parsed) == ["value"] else text


def parse_assignment(text: str) -> tuple[str, object]:
    """``"KEY=VALUE"`` as ``(key, value)`` with the value parsed by :func:`parse_value`."""
    key, sep, value = text.partition("=")
    if not sep or not key.strip():
        raise SceneError("", f"--set takes KEY=VALUE (like scene.seed=7), got {text!r}")
    return key.strip(), parse_value(value.strip())


def split_key(key: str) -> list[str]:
    """The parts of a dotted key; parts holding a dot are quoted as in TOML."""
    if not isinstance(key, str):
        raise SceneError("", f"override keys must be strings, got {key!r}")
    if '"' not in key and "'" not in key:
        parts = [part.strip() for part in key.split(".")]
    else:
        try:
            node = tomllib.loads(f"{key} = 0") if "\n" not in key else None
        except tomllib.TOMLDecodeError:
            node = None
        parts = []
        while isinstance(node, dict) and len(node) == 1:
            ((part, node),) = node.items()
            parts.append(part)
        if node != 0:
            parts = []
    if not parts or not all(parts):
        raise SceneError(
            "", f"override key {key!r} must be a dotted path like system.0.emitter.0.rate"
        )
    return parts


def apply_overrides(data: dict, overrides: Mapping[str, object]) -> None:
    """Set each ``key: value`` of ``overrides`` in ``data``, a parsed TOML document."""
    for key, value in overrides.items():
        _assign(data, key, split_key(key), _plain(value))


def _plain(value):
    """A value as TOML parsing gives it: tuples as lists, NumPy scalars as Python ones."""
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, np.generic):
        return value.item()
    return value


def _assign(data: dict, key: str, parts: list[str], value) -> None:
    node, path = data, ""
    for depth, part in enumerate(parts):
        last = depth == len(parts) - 1
        if isinstance(node, dict):
            child_path = f"{path}.{part}" if path else part
            if part not in node:
                if part.isdigit():
                    what = "is" if path else "the scene's top level is"
                    raise SceneError(
                        path, f"{what} a table, not an array: override {key!r} cannot index it"
                    )
                if not last and parts[depth + 1].isdigit():
                    raise SceneError(
                        child_path, f"is not in the scene: override {key!r} has nothing to index"
                    )
                if not last:
                    node[part] = {}  # a table the file leaves out
            if last:
                node[part] = value
                return
            node, path = node[part], child_path
        elif isinstance(node, list):
            index = _index(node, part, path, key)
            if last:
                node[index] = value
                return
            node, path = node[index], f"{path}[{index}]"
        else:
            raise SceneError(
                path, f"is {_kind(node)} {node!r}, not a table: override {key!r} cannot go into it"
            )


def _index(items: list, part: str, path: str, key: str) -> int:
    """The entry of array ``items`` that ``part`` names: an index, or a ``name``."""
    if part.isdigit():
        index = int(part)
        if index >= len(items):
            raise SceneError(
                path,
                f"index {index} in override {key!r} is out of range (the array has "
                f"{len(items)} entr{'y' if len(items) == 1 else 'ies'})",
            )
        return index
    names = [item.get("name") if isinstance(item, dict) else None for item in items]
    if part in names:
        return names.index(part)
    named = [n for n in names if isinstance(n, str)]
    if not named:
        raise SceneError(
            path, f"has no named entries: index it by number in override {key!r} (from 0)"
        )
    guess = close_matches(part, named)
    hint = f"did you mean {guess[0]!r}? " if guess else ""
    raise SceneError(
        path,
        f"no entry named {part!r} in override {key!r}; {hint}names here: "
        f"{', '.join(map(repr, named))}",
    )
