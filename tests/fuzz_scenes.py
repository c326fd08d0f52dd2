"""Scene files for the property-based fuzzer (``tests/test_fuzz.py``).

The seeds are the built-in scenes and ``examples/scenes``, parsed. A mutation changes one
place of a parsed scene: it deletes a key or an array entry, adds an unknown key, puts a
value of the wrong type, an extreme number (``1e300``, ``-1``, ``0``, ``nan``, ``inf``, a
64-bit overflow), a huge array, an empty string, deep nesting or a value from elsewhere
in the seeds in its place, or repeats an array entry (two systems of one name):
:func:`mutated_scene`. :func:`renumbered_scene` changes only numbers (and deletes keys),
so that more of its scenes load and run. The mutated scene is written back as TOML text
(:func:`to_toml`) so that the loader reads it as a user's file would be read; a
:class:`Case` holds it. :func:`mangled_bytes` makes byte-level damage: truncated files,
flipped bytes, spliced seeds, random bytes.
"""

from __future__ import annotations

import copy
import math
import re
import reprlib
import tomllib
from pathlib import Path

from hypothesis import strategies as st

ROOT = Path(__file__).resolve().parents[1]
SEED_FILES = sorted((ROOT / "src/motes/scene/builtin").glob("*.toml")) + sorted(
    (ROOT / "examples/scenes").glob("*.toml")
)
#: Seed scene name -> its TOML text.
SEED_TEXTS = {path.stem: path.read_text() for path in SEED_FILES}
#: Seed scene name -> its parsed TOML (never mutated: mutations copy).
SEEDS = {name: tomllib.loads(text) for name, text in SEED_TEXTS.items()}


class Deep:
    """``n`` nested empty arrays, ``[[[...]]]``: written directly, not built as lists."""

    def __init__(self, depth: int):
        self.depth = depth

    def __repr__(self) -> str:
        return f"Deep({self.depth})"


class Huge:
    """An array of ``length`` copies of ``item`` (written directly)."""

    def __init__(self, length: int, item):
        self.length, self.item = length, item

    def __repr__(self) -> str:
        return f"Huge({self.length}, {self.item!r})"


class Case:
    """A mutated seed: its TOML ``text``, shown (by hypothesis, on failure) as the seed's
    name and the mutations, shortened, rather than as the whole text."""

    def __init__(self, seed: str, mutations: tuple, text: str):
        self.seed, self.mutations, self.text = seed, mutations, text

    def __repr__(self) -> str:
        return f"Case({self.seed!r}, {_SHORT.repr(self.mutations)})"


_SHORT = reprlib.Repr()
_SHORT.maxlevel, _SHORT.maxlist, _SHORT.maxtuple, _SHORT.maxstring = 6, 8, 8, 80


# --- writing TOML -------------------------------------------------------------------------

_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def _key(key: str) -> str:
    return key if _BARE_KEY.fullmatch(key) else _string(key)


def _string(text: str) -> str:
    out = []
    for ch in text:
        code = ord(ch)
        if ch in '"\\':
            out.append("\\" + ch)
        elif code < 0x20 or code == 0x7F:
            out.append(f"\\u{code:04x}")
        elif 0xD800 <= code <= 0xDFFF:  # a lone surrogate cannot be written in UTF-8
            out.append("\\ufffd")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return _string(value)
    if isinstance(value, Deep):
        return "[" * value.depth + "]" * value.depth
    if isinstance(value, Huge):
        return "[" + ", ".join([_value(value.item)] * value.length) + "]"
    if isinstance(value, list):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    if isinstance(value, dict):
        if not value:
            return "{}"
        return "{ " + ", ".join(f"{_key(k)} = {_value(v)}" for k, v in value.items()) + " }"
    raise TypeError(f"cannot write {value!r} as TOML")


def to_toml(doc: dict) -> str:
    """``doc`` as TOML text: one ``key = value`` line per top-level key, inline below."""
    return "".join(f"{_key(k)} = {_value(v)}\n" for k, v in doc.items()) + "\n"


# --- places and mutations -----------------------------------------------------------------


def places(doc) -> list[tuple]:
    """Every place in ``doc``: the key path (a tuple of keys and indices) of each value."""
    found = []

    def walk(node, path):
        if isinstance(node, dict):
            for k, v in node.items():
                found.append((*path, k))
                walk(v, (*path, k))
        elif isinstance(node, list):
            for i, v in enumerate(node):
                found.append((*path, i))
                walk(v, (*path, i))

    walk(doc, ())
    return found


def containers(doc) -> list[tuple]:
    """Paths of every table (dict) in ``doc``, the root ``()`` first."""
    found = [()]
    for path in places(doc):
        if isinstance(_at(doc, path), dict):
            found.append(path)
    return found


def _at(doc, path):
    node = doc
    for step in path:
        node = node[step]
    return node


def _parent(doc, path):
    return _at(doc, path[:-1]), path[-1]


def _leaf_values(docs) -> list:
    """Every scalar and small array in the seeds: values to move elsewhere."""
    values = []
    for doc in docs:
        for path in places(doc):
            v = _at(doc, path)
            if not isinstance(v, (dict, list)) or (
                isinstance(v, list) and len(v) <= 4 and not any(isinstance(x, dict) for x in v)
            ):
                values.append(v)
    unique = []
    for v in values:
        if v not in unique:
            unique.append(v)
    return unique


#: Values from elsewhere in the seeds (type names, vectors, colours, counts...).
SEED_VALUES = _leaf_values(SEEDS.values())

#: Numbers at and past every boundary a scene key might have.
EXTREME_NUMBERS = [
    0, -1, 1, 2, 0.0, -0.0, -1.0, 0.5, 1e-300, 5e-324, 1e300, -1e300, 1.7976931348623157e308,
    math.nan, math.inf, -math.inf, 2**31, 2**53 + 1, 2**63 - 1, 2**63, 2**64, -(2**63),
    -(2**63) - 1, 10**30, 10**9, 100_000_001, 16385, 1001,
]  # fmt: skip

#: Values of the wrong kind for most keys.
WRONG_TYPES = [
    "", " ", "x", "🙂", "a.b", "\x00", "#", "#ff", "nan", True, False, [], [[]], {}, {"": 1},
    [1, 2], [1, 2, 3, 4, 5], ["a", "b", "c"], [math.nan, 0, 0], [0, math.inf, 0], [1e300] * 3,
    [[0, 0, 0]], [0, 0, 0], {"type": ""}, {"uniform": []}, {"uniform": [1]},
    {"normal": [0, -1]}, {"gradient": []}, {"times": [], "points": []},
]  # fmt: skip

#: Unknown keys to add (including ones no TOML bare key could be).
UNKNOWN_KEYS = ["typo", "nmae", "type ", "", "a.b", "a\nb", "🙂", "x" * 5000, "__class__"]


def _huge_values():
    return [
        Huge(100_000, 0),
        Huge(20_000, [0, 0, 0]),
        Huge(5_000, {"type": "gravity"}),
        Deep(50),
        Deep(600),
        Deep(5_000),
        "x" * 100_000,
    ]


@st.composite
def mutated_scene(draw, seeds=None, max_mutations: int = 3):
    """A :class:`Case`: a seed with up to ``max_mutations`` mutations."""
    names = sorted(SEEDS if seeds is None else seeds)
    name = draw(st.sampled_from(names))
    doc = copy.deepcopy(SEEDS[name])
    done = []
    for _ in range(draw(st.integers(1, max_mutations))):
        done.append(draw(_mutation(doc)))
    return Case(name, tuple(done), to_toml(doc))


def _number_near(value):
    """Numbers derived from a seed's own number: scaled, negated, the other type."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        return st.nothing()
    options = [-value, value * 1e6, value * 1e-6, value + 0.5, value * 1e15]
    if isinstance(value, int):
        options += [float(value), value * 10**6, value * 10**12]
    elif abs(value) < 1e15:
        options += [round(value)]
    return st.sampled_from(options)


@st.composite
def _mutation(draw, doc):
    """Apply one mutation to ``doc`` in place; return what was done."""
    kind = draw(st.sampled_from(["delete", "add_key", "replace", "replace", "replace", "repeat"]))
    if kind == "add_key":
        where = draw(st.sampled_from(containers(doc)))
        key = draw(st.sampled_from(UNKNOWN_KEYS))
        value = draw(st.sampled_from([1, "x", {}, [1]]))
        _at(doc, where)[key] = value
        return ("add_key", where, key)
    spots = places(doc)
    if not spots:
        return ("nothing",)
    path = draw(st.sampled_from(spots))
    parent, last = _parent(doc, path)
    if kind == "delete":
        del parent[last]
        return ("delete", path)
    if kind == "repeat":
        if isinstance(parent, list):
            parent.append(copy.deepcopy(parent[last]))
            return ("repeat", path)
        kind = "replace"
    old = parent[last]
    value = draw(
        st.one_of(
            st.sampled_from(EXTREME_NUMBERS),
            st.sampled_from(WRONG_TYPES),
            st.sampled_from(SEED_VALUES),
            st.sampled_from(_huge_values()),
            _number_near(old),
            st.floats(allow_nan=True, allow_infinity=True),
            st.integers(-(2**70), 2**70),
            st.text(max_size=8),
        )
    )
    parent[last] = copy.deepcopy(value)
    return ("replace", path, value)


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


@st.composite
def renumbered_scene(draw, seeds=None, max_mutations: int = 2):
    """A :class:`Case`: a seed with numbers changed (extreme, scaled, the other type) or
    keys deleted; the file keeps its shape, so more of them load and run than of
    :func:`mutated_scene`'s."""
    names = sorted(SEEDS if seeds is None else seeds)
    name = draw(st.sampled_from(names))
    doc = copy.deepcopy(SEEDS[name])
    done = []
    for _ in range(draw(st.integers(1, max_mutations))):
        numbers = [p for p in places(doc) if _is_number(_at(doc, p))]
        if not numbers or draw(st.integers(0, 4)) == 0:
            path = draw(st.sampled_from(places(doc)))
            parent, last = _parent(doc, path)
            del parent[last]
            done.append(("delete", path))
            continue
        path = draw(st.sampled_from(numbers))
        parent, last = _parent(doc, path)
        value = draw(
            st.one_of(
                st.sampled_from(EXTREME_NUMBERS),
                _number_near(parent[last]),
                st.floats(allow_nan=False, allow_infinity=False),
            )
        )
        parent[last] = value
        done.append(("replace", path, value))
    return Case(name, tuple(done), to_toml(doc))


@st.composite
def mangled_bytes(draw):
    """Bytes of a damaged scene file: a seed cut short, with bytes flipped, or noise."""
    kind = draw(st.sampled_from(["truncate", "flip", "random", "splice"]))
    name = draw(st.sampled_from(sorted(SEED_TEXTS)))
    data = SEED_TEXTS[name].encode()
    if kind == "truncate":
        return data[: draw(st.integers(0, len(data)))]
    if kind == "flip":
        data = bytearray(data)
        for _ in range(draw(st.integers(1, 8))):
            i = draw(st.integers(0, len(data) - 1))
            data[i] = draw(st.integers(0, 255))
        return bytes(data)
    if kind == "splice":
        other = SEED_TEXTS[draw(st.sampled_from(sorted(SEED_TEXTS)))].encode()
        cut = draw(st.integers(0, len(data)))
        start = draw(st.integers(0, len(other)))
        return data[:cut] + other[start:]
    return draw(st.binary(max_size=2000))
