"""Memory estimates, checked before large allocations.

Constructors that allocate in proportion to a parameter (a store's ``capacity``, a cloth
grid's vertices, a liquid's particles, a renderer's pixels) call :func:`check` with what
they will need before allocating, so that a mistyped size fails at once with the
parameter, the estimate and what is available, instead of swapping the machine to a halt
or being killed halfway through a run.

The limit is the memory available now (:func:`available`), or the number of bytes in the
environment variable ``MOTES_MEMORY_LIMIT`` when it is set (tests set it; so can a user on
a shared machine). Each object checks its own needs when it is made: objects made earlier
and not yet filled (NumPy's ``empty`` reserves pages the system hands out on first write)
are not subtracted.
"""

from __future__ import annotations

import os

#: Environment variable: the memory [bytes] objects may use, instead of what is available.
LIMIT_VARIABLE = "MOTES_MEMORY_LIMIT"

#: Needs below this [bytes] are not compared with the system's memory (it is not read):
#: no machine that runs Python has less free.
_SMALL = 1 << 20


class InsufficientMemoryError(MemoryError, ValueError):
    """An object would need more memory than is available; raised before allocating.

    A ``MemoryError``, and a ``ValueError`` because the cause is a parameter's value
    (scene files report it with the key path, like every other bad value).
    """


def format_bytes(count: float) -> str:
    """``count`` bytes in decimal units: ``'512 B'``, ``'15.2 GB'``."""
    value = float(count)
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if value < 999.95 or unit == "PB":
            break
        value /= 1000.0
    return f"{value:.0f} B" if unit == "B" else f"{value:.1f} {unit}"


def _limit_from_environment() -> int | None:
    text = os.environ.get(LIMIT_VARIABLE, "").strip()
    if not text:
        return None
    try:
        limit = int(text)
    except ValueError:
        raise ValueError(
            f"{LIMIT_VARIABLE} must be a whole number of bytes, got {text!r}"
        ) from None
    if limit < 0:
        raise ValueError(f"{LIMIT_VARIABLE} must be >= 0 bytes, got {limit}")
    return limit


def _meminfo_available() -> int | None:
    """Linux's estimate of memory available without swapping (``MemAvailable``), bounded
    by the cgroup's limit in a container. ``SC_AVPHYS_PAGES`` counts free pages only and
    not the file cache the kernel gives back on demand, so on a machine that has read
    many files it reports far less than a program can have."""
    try:
        with open("/proc/meminfo", "rb") as file:
            for line in file:
                if line.startswith(b"MemAvailable:"):
                    found = int(line.split()[1]) * 1024
                    break
            else:
                return None
    except (OSError, ValueError, IndexError):
        return None
    try:
        with open("/sys/fs/cgroup/memory.max", "rb") as file:
            ceiling = file.read().strip()
        with open("/sys/fs/cgroup/memory.current", "rb") as file:
            used = int(file.read().strip())
        if ceiling != b"max":
            found = min(found, max(0, int(ceiling) - used))
    except (OSError, ValueError):
        pass
    return found


def _sysconf(name: str) -> int | None:
    try:
        value = os.sysconf(name) * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):  # no sysconf (Windows), or no such name
        return None
    return value if value > 0 else None


def available() -> tuple[int, str] | None:
    """The memory objects may use [bytes] and where the number comes from, or ``None``
    where it cannot be known (then nothing is refused).

    In order: ``MOTES_MEMORY_LIMIT``; Linux's ``MemAvailable`` (within a cgroup's
    limit); free physical pages (``SC_AVPHYS_PAGES``); the physical memory
    (``SC_PHYS_PAGES``: macOS has no count of free pages).
    """
    limit = _limit_from_environment()
    if limit is not None:
        return limit, f"that {LIMIT_VARIABLE} allows"
    for found in (_meminfo_available, lambda: _sysconf("SC_AVPHYS_PAGES")):
        value = found()
        if value is not None:
            return value, "available"
    value = _sysconf("SC_PHYS_PAGES")
    return (value, "of physical memory") if value is not None else None


def check(what: str, needed: float, *, per: str = "") -> None:
    """Raise :class:`InsufficientMemoryError` if ``needed`` bytes exceed the limit.

    ``what`` starts with the parameter's name and its value (``"capacity = 10000000"``),
    so that scene files can point at the key; ``per`` explains the estimate
    (``"41 B per particle"``).
    """
    if needed <= _SMALL and os.environ.get(LIMIT_VARIABLE) is None:
        return
    found = available()
    if found is None:
        return
    limit, source = found
    if needed > limit:
        detail = f" ({per})" if per else ""
        raise InsufficientMemoryError(
            f"{what} would need about {format_bytes(needed)} of memory{detail}, more than "
            f"the {format_bytes(limit)} {source}"
        )
