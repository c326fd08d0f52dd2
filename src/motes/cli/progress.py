"""A one-line progress bar for long runs: frames done, frames per second, time left."""

from __future__ import annotations

import sys
import time


class Progress:
    """Redraws ``label [#####.....] 12/240  23.4 fps  9 s left`` on one terminal line.

    Writes to ``stream`` (stderr by default) at most ``rate`` times a second; does nothing
    when ``enabled`` is false (``--quiet``). When the stream is not a terminal (a log
    file, a pipe), it writes a plain line at most once a second instead of redrawing.
    """

    def __init__(
        self,
        total: int,
        *,
        label: str = "",
        enabled: bool = True,
        stream=None,
        rate: float = 10.0,
        width: int = 24,
    ):
        self.total = total
        self.label = label
        self.enabled = enabled
        self.stream = stream or sys.stderr
        self.interval = 1.0 / rate
        self.width = width
        self.start = time.perf_counter()
        self.last = -1.0
        self.done = 0
        self.first: float | None = None  # when the first frame was done
        self.closed = False
        self.redraw = bool(getattr(self.stream, "isatty", lambda: False)())

    def begin(self) -> None:
        """Say that the first frame is on its way: on a first run it takes the time the
        kernels need to compile (tens of seconds), with nothing else to show."""
        if self.enabled and self.total:
            self.stream.write(
                f"{self.label}: first frame (kernels compile on a first run and are "
                "cached for the next)...\n"
            )
            self.stream.flush()

    def update(self, done: int) -> None:
        self.done = done
        now = time.perf_counter()
        if done == 1:
            self.first = now
        if not self.enabled:
            return
        if self.redraw and (now - self.last >= self.interval or done == self.total):
            self.last = now
            self.stream.write("\r" + self.line(now))
            self.stream.flush()
        elif not self.redraw and (now - self.last >= 1.0 or done == self.total):
            self.last = now
            self.stream.write(self.line(now) + "\n")
            self.stream.flush()

    def line(self, now: float | None = None) -> str:
        now = now or time.perf_counter()
        elapsed = now - self.start
        fps = self.done / elapsed if elapsed > 0 else 0.0
        # The time left comes from the frames after the first: the first one carries
        # the kernels' compilation and would make the estimate hours long.
        steady = now - self.first if self.first is not None else 0.0
        rate = (self.done - 1) / steady if self.done >= 2 and steady > 0 else 0.0
        left = (self.total - self.done) / rate if rate > 0 else float("inf")
        filled = int(self.width * self.done / max(self.total, 1))
        bar = "#" * filled + "." * (self.width - filled)
        eta = f"{left:5.0f} s left" if left != float("inf") else "     ? s left"
        return f"{self.label} [{bar}] {self.done}/{self.total}  {fps:5.1f} fps  {eta}"

    def close(self) -> None:
        """End the line (once; later calls do nothing)."""
        if self.enabled and self.redraw and self.last >= 0 and not self.closed:
            self.closed = True
            self.stream.write("\n")
            self.stream.flush()
