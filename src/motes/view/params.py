"""A scene file's numeric values as the viewer's controls, and saving them back.

Every number (or pair or triple of numbers) of a scene's ``[scene]``, ``[[system]]``,
``[[body]]`` and ``[[collider]]`` tables is a :class:`Parameter`, keyed by the path
``motes run --set`` takes (``system.flame.emitter.0.rate.rate``). The camera, lights
and render settings are left out: the browser has its own camera and draws without
them. A parameter is *live* when changing it can act on the running simulation from
the next step: those of a system's emitters, forces, modifiers, colliders and
collisions, and a body's :data:`~motes.scene.bodies.LIVE_KEYS` (a liquid's solver
settings and forces, a cloth's or hair's springs and drag, a grid fluid's forces and
dissipation, a flock's rules and limits). The rest (a scene's duration or seed, a
system's capacity, a rigid world's values) act when the scene restarts.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

from ..scene.bodies import LIVE_KEYS
from ..scene.overrides import apply_overrides

__all__ = ["LIVE_PARTS", "Parameter", "parameters", "save_scene"]

#: Tables of a ``[[system]]`` whose values act from the next step.
LIVE_PARTS = ("emitter", "force", "modifier", "collider", "collisions")
#: Top-level tables whose values become controls.
SECTIONS = ("scene", "system", "body", "collider")
#: Keys of those tables that are not controls (how a part is drawn, its name).
SKIPPED = ("render", "name", "description")


@dataclass(frozen=True)
class Parameter:
    """One numeric value of a scene file.

    ``key`` is its ``--set`` path, ``group`` the part it belongs to (``scene``,
    ``system flame``, ``body cloth``, ``collider 0``), ``label`` the rest of the path,
    ``value`` a number or a tuple of 2 or 3 numbers, ``live`` whether it acts from the
    next step (else at restart).
    """

    key: str
    group: str
    label: str
    value: float | int | tuple
    live: bool

    @property
    def integer(self) -> bool:
        values = self.value if isinstance(self.value, tuple) else (self.value,)
        return all(isinstance(v, int) for v in values)


def parameters(text: str, overrides: dict | None = None) -> list[Parameter]:
    """The :class:`Parameter` s of scene file ``text`` with ``overrides`` set over it,
    in file order."""
    data = tomllib.loads(text)
    apply_overrides(data, overrides or {})
    found: list[Parameter] = []
    for section in SECTIONS:
        value = data.get(section)
        if isinstance(value, dict):
            _walk(value, section, "scene", "", False, found)
        elif isinstance(value, list):
            for index, table in enumerate(value):
                if not isinstance(table, dict):
                    continue
                name = table.get("name")
                part = name if isinstance(name, str) and _plain(name) else str(index)
                group = f"{section} {part}"
                for key, item in table.items():
                    if key in SKIPPED:
                        continue
                    live = (section == "system" and key in LIVE_PARTS) or (
                        section == "body" and key in LIVE_KEYS.get(table.get("type"), ())
                    )
                    _walk_item(item, f"{section}.{part}.{key}", group, key, live, found)
    return found


def _plain(name: str) -> bool:
    """A name usable bare in a key path (else the entry is keyed by its index)."""
    return name.replace("_", "").replace("-", "").isalnum()


def _walk(table: dict, path: str, group: str, label: str, live: bool, found: list) -> None:
    for key, item in table.items():
        if key in SKIPPED:
            continue
        _walk_item(item, f"{path}.{key}", group, f"{label}.{key}" if label else key, live, found)


def _walk_item(item, path: str, group: str, label: str, live: bool, found: list) -> None:
    if isinstance(item, dict):
        # a force that rides a body's flow is kept as it was: it acts at restart
        linked = item.get("type") == "grid_flow"
        _walk(item, path, group, label, live and not linked, found)
    elif isinstance(item, list) and item and all(isinstance(v, dict) for v in item):
        for index, sub in enumerate(item):
            _walk_item(sub, f"{path}.{index}", group, f"{label}.{index}", live, found)
    elif _number(item):
        found.append(Parameter(path, group, label, item, live))
    elif isinstance(item, list) and len(item) in (2, 3) and all(map(_number, item)):
        found.append(Parameter(path, group, label, tuple(item), live))


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def save_scene(text: str, overrides: dict, path: Path) -> None:
    """Write scene file ``text`` with ``overrides`` set over it to ``path``, keeping the
    file's comments and layout (tomlkit), atomically (a failed write leaves no file)."""
    import tomlkit

    from ..io._atomic import replacing

    document = tomlkit.parse(text)
    apply_overrides(document, overrides)
    with replacing(Path(path)) as temporary:
        temporary.write_text(tomlkit.dumps(document))
