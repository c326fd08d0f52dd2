"""Reading validated values out of parsed TOML, with errors that name the key path.

Every value read from a scene file goes through a :class:`Table`, which records which
keys were asked for. Reading a table ends with :meth:`Table.finish`, which rejects any key
nobody asked for (a typo must not be silently ignored) and lists the allowed ones.
"""

from __future__ import annotations

import difflib
import math
import re
import reprlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..color import parse_color


class SceneError(ValueError):
    """A mistake in a scene: ``path`` is the key path (``system[0].emitter[1].rate``)."""

    def __init__(self, path: str, message: str):
        self.path = path
        self.message = message
        super().__init__(f"{path}: {message}" if path else message)


_REQUIRED = object()

#: A reader converts one raw TOML value at ``path`` or raises SceneError.
Reader = Callable[[Any, str], Any]


def _short_repr() -> reprlib.Repr:
    short = reprlib.Repr()
    short.maxlevel, short.maxlist, short.maxdict = 3, 6, 6
    short.maxstring = short.maxother = 60
    short.maxlong = 24
    return short


_SHORT = _short_repr()


def shown(value) -> str:
    """``repr(value)``, shortened (``[0, 0, 0, 0, 0, 0, ...]``, ``'xxxx...xxxx'``): a
    message must stay one readable line whatever the file holds."""
    return _SHORT.repr(value)


def listed(items, limit: int = 12) -> str:
    """``'a', 'b', 'c'``: the items shown and comma-separated, at most ``limit`` of them."""
    items = list(items)
    text = ", ".join(shown(item) for item in items[:limit])
    return text + f", ... ({len(items)} in all)" if len(items) > limit else text


def _kind(value) -> str:
    return {
        bool: "boolean",
        int: "integer",
        float: "number",
        str: "string",
        list: "array",
        dict: "table",
    }.get(type(value), type(value).__name__)


class Table:
    """A TOML table being read; see the module docstring."""

    def __init__(self, data, path: str):
        if not isinstance(data, dict):
            raise SceneError(path, f"must be a table, got {_kind(data)} {shown(data)}")
        self.data = data
        self.path = path
        self.allowed: list[str] = []

    def key_path(self, key: str) -> str:
        return f"{self.path}.{key_name(key)}" if self.path else key_name(key)

    def has(self, key: str) -> bool:
        if key not in self.allowed:
            self.allowed.append(key)
        return key in self.data

    def get(self, key: str, reader: Reader, default=_REQUIRED):
        """The value of ``key`` converted by ``reader``; ``default`` when absent."""
        if not self.has(key):
            if default is _REQUIRED:
                self._missing(key)
            return default
        return reader(self.data[key], self.key_path(key))

    def table(self, key: str, *, optional: bool = False) -> Table | None:
        if not self.has(key):
            if optional:
                return None
            self._missing(key)
        return Table(self.data[key], self.key_path(key))

    def _missing(self, key: str):
        """A required key is absent: a misspelling of it is the likelier mistake."""
        for typo in self.data:
            if typo not in self.allowed and key in close_matches(typo, [key]):
                raise SceneError(self.key_path(typo), f"unknown key; did you mean {key!r}?")
        unread = [k for k in self.data if k not in self.allowed]
        found = f" (this table has {listed(unread)})" if unread else ""
        raise SceneError(self.key_path(key), f"is required{found}")

    def tables(self, key: str) -> list[Table]:
        """An array of tables (``[[key]]``); empty when absent."""
        if not self.has(key):
            return []
        items = self.data[key]
        if isinstance(items, dict):
            items = [items]
        if not isinstance(items, list):
            raise SceneError(self.key_path(key), f"must be an array of tables, got {_kind(items)}")
        return [Table(item, f"{self.key_path(key)}[{i}]") for i, item in enumerate(items)]

    def finish(self) -> None:
        """Reject keys that were never asked for."""
        unknown = [k for k in self.data if k not in self.allowed]
        if unknown:
            allowed = ", ".join(self.allowed) if self.allowed else "none"
            guess = close_matches(unknown[0], self.allowed)
            hint = f"did you mean {guess[0]!r}? " if guess else ""
            raise SceneError(
                self.key_path(unknown[0]), f"unknown key; {hint}allowed here: {allowed}"
            )


_BARE_KEY = re.compile(r"[A-Za-z0-9_-]{1,60}")


def key_name(key: str) -> str:
    """``key`` as it appears in a key path: bare, or quoted and shortened when TOML
    would need quotes for it (a key may hold dots, spaces, line breaks, or be long)."""
    return key if _BARE_KEY.fullmatch(key) else shown(key)


def close_matches(word: str, choices) -> list[str]:
    """The choices ``word`` is probably a misspelling of, best first."""
    return difflib.get_close_matches(word, list(choices), n=3, cutoff=0.6)


def build(path: str, factory: Callable, *args, **kwargs):
    """Call a library constructor, re-raising its validation errors with the key path.

    Constructors name the parameter first in their messages (``radius must be > 0``);
    when that parameter is a key of the table, the path points at it.
    """
    try:
        return factory(*args, **kwargs)
    except SceneError:
        raise  # a reader inside the factory named its key already
    except (ValueError, TypeError) as error:
        message = _clipped(str(error))
        first = message.split(" ", 1)[0]
        if first in kwargs:
            raise SceneError(f"{path}.{first}", message) from None
        raise SceneError(path, message) from None


def _clipped(message: str, limit: int = 400) -> str:
    """A library message on one line of at most ``limit`` characters (constructors quote
    the values they were given, which a file can make as long as it likes)."""
    message = " ".join(message.split())
    if len(message) <= limit:
        return message
    return f"{message[: limit - 80]} ... {message[-70:]}"


# --- scalar readers -----------------------------------------------------------------------


#: Magnitudes a scene number may have besides 0: the number, its square and its inverse
#: are then normal float32 values (particle attributes are float32), so no value in a
#: file overflows, or turns into 0 or inf, on its way into a kernel.
SMALLEST, LARGEST = 1e-18, 1e18


def number(
    low: float | None = None, high: float | None = None, *, low_open=False, high_open=False
) -> Reader:
    """A finite number (integers accepted) in the given range, 0 or of magnitude in
    [:data:`SMALLEST`, :data:`LARGEST`]."""

    def read(value, path):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise SceneError(path, f"must be a number, got {_kind(value)} {shown(value)}")
        if isinstance(value, float) and not math.isfinite(value):
            raise SceneError(path, f"must be finite, got {value}")
        if low is not None and (value < low or (low_open and value == low)):
            sign = ">" if low_open else ">="
            raise SceneError(path, f"must be {sign} {low}, got {shown(value)}")
        if high is not None and (value > high or (high_open and value == high)):
            sign = "<" if high_open else "<="
            raise SceneError(path, f"must be {sign} {high}, got {shown(value)}")
        if value != 0 and not SMALLEST <= abs(value) <= LARGEST:
            raise SceneError(
                path,
                f"must be 0 or between {SMALLEST:g} and {LARGEST:g} in magnitude (motes "
                f"computes in float32), got {shown(value)}",
            )
        return float(value)

    return read


def positive() -> Reader:
    return number(0.0, low_open=True)


def integer(low: int | None = None, high: int | None = None) -> Reader:
    def read(value, path):
        if isinstance(value, bool) or not isinstance(value, int):
            raise SceneError(path, f"must be an integer, got {_kind(value)} {shown(value)}")
        if low is not None and value < low:
            raise SceneError(path, f"must be >= {low}, got {shown(value)}")
        if high is not None and value > high:
            raise SceneError(path, f"must be <= {high}, got {shown(value)}")
        return value

    return read


def boolean(value, path):
    if not isinstance(value, bool):
        raise SceneError(path, f"must be true or false, got {_kind(value)} {shown(value)}")
    return value


def string(value, path):
    if not isinstance(value, str):
        raise SceneError(path, f"must be a string, got {_kind(value)} {shown(value)}")
    return value


#: A scene name: it names the default output file, so it must stay a plain file name.
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,99}")


def file_name(value, path):
    """A plain file name (letters, digits, ``_``, ``-``, ``.``; no directories), at most
    100 characters: safe to use as an output file name in the current directory."""
    text = string(value, path)
    if not _NAME.fullmatch(text):
        raise SceneError(
            path,
            f"must be a plain name of letters, digits, '_', '-' and '.' (at most 100, "
            f"starting with a letter or digit, no '/' or '..'), got {shown(text)}",
        )
    return text


def scene_file(base: Path, *, suffixes: tuple[str, ...] = (), what: str = "file") -> Reader:
    """An existing file named relative to the scene file's folder ``base``.

    A relative path must stay inside ``base`` (``../`` that leaves it is refused, so a
    scene cannot reach files beside it by accident); an absolute path is taken as is.
    ``suffixes`` (lower case, with the dot) limits the file types; ``what`` names the
    kind of file in messages.
    """

    def read(value, path):
        text = string(value, path)
        if not text:
            raise SceneError(path, "must be a file name, got ''")
        given = Path(text).expanduser()
        if given.is_absolute():
            resolved = given.resolve()
        else:
            root = Path(base).resolve()
            resolved = (root / given).resolve()
            if not resolved.is_relative_to(root):
                raise SceneError(
                    path,
                    f"{shown(text)} leaves the scene file's folder {str(root)!r}; "
                    "use a path inside it or an absolute path",
                )
        if suffixes and resolved.suffix.lower() not in suffixes:
            allowed = ", ".join(suffixes)
            raise SceneError(path, f"must be a {allowed} file, got {shown(text)}")
        if not resolved.is_file():
            raise SceneError(path, f"{what} not found (cannot read {resolved})")
        return resolved

    return read


def one_of(*choices: str) -> Reader:
    def read(value, path):
        if value not in choices:
            allowed = listed(choices, limit=40)
            raise SceneError(path, f"must be one of {allowed}, got {shown(value)}")
        return value

    return read


def vector(size: int = 3) -> Reader:
    """An array of ``size`` numbers, as a tuple of floats."""

    def read(value, path):
        if not isinstance(value, list) or len(value) != size:
            raise SceneError(path, f"must be an array of {size} numbers, got {shown(value)}")
        return tuple(number()(v, f"{path}[{i}]") for i, v in enumerate(value))

    return read


def color(value, path):
    """A colour: ``"#rrggbb[aa]"`` (sRGB) or an array of 3 or 4 linear values."""
    if isinstance(value, str) or (
        isinstance(value, list)
        and len(value) in (3, 4)
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
    ):
        if isinstance(value, list):
            value = [number(0.0)(v, f"{path}[{i}]") for i, v in enumerate(value)]
        try:
            return tuple(parse_color(value))
        except ValueError:
            if isinstance(value, str):
                allowed = "must be a colour like '#rrggbb' or '#rrggbbaa'"
            else:
                allowed = "must be a colour of 3 or 4 finite values >= 0"
            raise SceneError(path, f"{allowed}, got {shown(value)}") from None
    raise SceneError(path, f'must be a colour like "#ff8800" or [r, g, b(, a)], got {shown(value)}')


def array_of(reader: Reader, *, min_length: int = 0, length: int | None = None) -> Reader:
    """An array whose entries ``reader`` reads: at least ``min_length`` of them, or
    exactly ``length``."""

    def read(value, path):
        if not isinstance(value, list):
            raise SceneError(path, f"must be an array, got {_kind(value)} {shown(value)}")
        if len(value) < min_length:
            raise SceneError(path, f"needs at least {min_length} entries, got {len(value)}")
        if length is not None and len(value) != length:
            raise SceneError(path, f"must have {length} entries, got {len(value)}")
        return [reader(v, f"{path}[{i}]") for i, v in enumerate(value)]

    return read


def keyed(value_reader: Reader) -> Reader:
    """Curve keys: an array of ``[t, value]`` pairs with t in [0, 1]."""

    def read_key(value, path):
        if not isinstance(value, list) or len(value) != 2:
            raise SceneError(path, f"must be a [time, value] pair, got {shown(value)}")
        return number(0.0, 1.0)(value[0], f"{path}[0]"), value_reader(value[1], f"{path}[1]")

    return array_of(read_key, min_length=1)
