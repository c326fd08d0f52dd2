"""Helpers that keep output files whole when a run is interrupted.

Two tools, used by every writer in :mod:`motes.io`:

- :func:`replacing` writes a file under a temporary sibling name and moves it into
  place with :func:`os.replace` only once it is complete. ``os.replace`` is atomic on
  POSIX and Windows when both names are on one file system, which a sibling in the same
  directory guarantees: a reader sees the old file or the new one, never a half-written
  one, and an interrupted write leaves the old file as it was.
- :class:`DeferredInterrupt` postpones ``SIGINT`` (Ctrl-C) across a short critical
  section, so that a frame is either wholly handed to its file or not at all, and the
  writer's bookkeeping matches what was written.

Atomicity here is against the process being interrupted or failing, not against power
loss: nothing is ``fsync``-ed. A process killed outright (``SIGKILL``, or ``SIGTERM``
without a handler) leaves its temporary file behind under a hidden name
(``.NAME.<random>.part.SUFFIX``) next to the output.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import signal
import threading
from collections.abc import Iterator
from pathlib import Path


def temporary_sibling(path: Path) -> Path:
    """Create an empty, uniquely named hidden file next to ``path`` and return its path.

    The name keeps the suffix of ``path`` (``movie.mp4`` gives
    ``.movie.1f2e3d4c.part.mp4``) so tools that choose a format by suffix still work.
    The file is created with mode ``0o666`` minus the umask, like any new file, so the
    final file gets ordinary permissions (``tempfile.mkstemp`` would make it ``0o600``).
    """
    path = Path(path)
    for _ in range(100):
        candidate = path.with_name(f".{path.stem}.{secrets.token_hex(4)}.part{path.suffix}")
        try:
            fd = os.open(candidate, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            continue
        os.close(fd)
        return candidate
    raise FileExistsError(f"could not create a temporary file next to {path}")  # pragma: no cover


def discard(path: Path) -> None:
    """Remove ``path`` if it exists."""
    with contextlib.suppress(FileNotFoundError):
        os.remove(path)


@contextlib.contextmanager
def replacing(path: Path) -> Iterator[Path]:
    """Context manager: yield a temporary sibling of ``path``; move it into place on success.

    If the block raises (any exception, ``KeyboardInterrupt`` included), the temporary
    file is removed and ``path`` is left untouched.

    Examples
    --------
    >>> with replacing(Path("out.txt")) as tmp:  # doctest: +SKIP
    ...     tmp.write_text("complete")
    """
    path = Path(path)
    tmp = temporary_sibling(path)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        discard(tmp)
        raise


class DeferredInterrupt:
    """Context manager that holds back ``SIGINT`` until the block has finished.

    Inside the block a Ctrl-C is only recorded; on exit the previous handler is restored
    and, if a ``SIGINT`` arrived, called, which for Python's default handler raises
    ``KeyboardInterrupt`` there, after the block's work is complete. A blocking system
    call inside the block that the signal interrupts is retried (PEP 475), so the block
    runs to its end.

    A second ``SIGINT`` inside the block is passed on at once, so pressing Ctrl-C twice
    still stops a block that does not finish.

    Deferral is only possible in the main thread and when the current handler is a
    Python callable (the default one, or a user's); otherwise (another thread, ``SIGINT``
    ignored or left to the operating system) the block runs unprotected, as it would
    without this class.
    """

    def __init__(self):
        self._previous = None
        self._received: list[tuple[int, object]] = []

    def _record(self, signum, frame):
        if self._received:
            # A second Ctrl-C is obeyed at once: the way out if the block is stuck
            # (e.g. blocked writing to a subprocess that no longer reads).
            self._received.clear()
            self._previous(signum, frame)
            return
        self._received.append((signum, frame))

    def __enter__(self) -> DeferredInterrupt:
        if threading.current_thread() is threading.main_thread():
            current = signal.getsignal(signal.SIGINT)
            if callable(current):
                # A SIGINT that arrives after this call is dispatched to _record: Python
                # looks the handler up when it runs it, not when the signal arrives.
                self._previous = signal.signal(signal.SIGINT, self._record)
        return self

    def __exit__(self, *exc_info) -> None:
        previous, self._previous = self._previous, None
        if previous is None:
            return
        signal.signal(signal.SIGINT, previous)
        if self._received:
            signum, frame = self._received[0]
            self._received.clear()
            previous(signum, frame)
