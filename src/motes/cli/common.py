"""What every ``motes`` subcommand shares: the user's-mistake error, argument types, and
SIGTERM taken as Ctrl-C."""

from __future__ import annotations

import argparse
import contextlib
import os
import signal


class UserError(Exception):
    """A mistake in what the user asked for: reported in one line, exit status 2."""


def resolution(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"must look like 1280x720, got {text!r}") from None
    if not (1 <= width <= 16384 and 1 <= height <= 16384):
        raise argparse.ArgumentTypeError(f"width and height must be in [1, 16384], got {text}")
    return width, height


def positive(text: str) -> float:
    """An argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return value


def digits(text: str) -> int:
    """An argparse type: significant decimal digits, an integer in [1, 15]."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
    if not 1 <= value <= 15:
        raise argparse.ArgumentTypeError(f"must be in [1, 15], got {value}")
    return value


def frame_range(text: str) -> tuple[int | None, int | None]:
    """An argparse type: ``A:B``, either side optional (a Python slice of frames)."""
    try:
        start, stop = (int(v) if v.strip() else None for v in text.split(":"))
    except ValueError:
        message = f"must look like 10:20, 10: or :20, got {text!r}"
        raise argparse.ArgumentTypeError(message) from None
    return start, stop


def integer_from(low: int):
    """An argparse type: an integer >= ``low``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"must be >= {low}, got {value}")
        return value

    return parse


@contextlib.contextmanager
def terminate_as_interrupt():
    """SIGTERM ends a run like Ctrl-C: every output is closed with its finished frames.

    The handler re-raises the signal as SIGINT, so it takes the same path, including
    the frame writers' deferral of Ctrl-C while a frame is handed over.
    """
    state = {"terminated": False}

    def handle(signum, frame):
        state["terminated"] = True
        os.kill(os.getpid(), signal.SIGINT)

    try:
        previous = signal.signal(signal.SIGTERM, handle)
    except ValueError:  # not the main thread: leave SIGTERM alone
        yield state
        return
    try:
        yield state
    finally:
        signal.signal(signal.SIGTERM, previous)


def dask_options(parser: argparse.ArgumentParser, *, workers: str, scheduler: str) -> None:
    """``--workers N`` or ``--scheduler ADDRESS`` (one of them), with their help texts."""
    farm = parser.add_mutually_exclusive_group()
    farm.add_argument("--workers", type=integer_from(1), metavar="N", help=workers)
    farm.add_argument("--scheduler", metavar="ADDRESS", help=scheduler)


def image_options(parser: argparse.ArgumentParser) -> None:
    """``--bits`` and ``--alpha``: what an image output holds beyond 8-bit RGB."""
    parser.add_argument(
        "--bits",
        type=int,
        choices=(8, 16),
        default=8,
        help="bits a channel of PNG output (16: through pypng, pip install 'motes[png16]')",
    )
    parser.add_argument(
        "--alpha",
        action="store_true",
        help="a transparent background and an alpha channel: premultiplied in NAME.exr, "
        "straight in PNG (geometry and alpha-blended particles cover, additive light does "
        "not: it is kept in OpenEXR only)",
    )
