"""Write frames to a video until interrupted: the subject of the Ctrl-C tests.

Run by ``tests/test_io_frames.py`` as ``python interrupt_writer.py OUTPUT LIMIT``: opens
a writer for OUTPUT, prints ``ready``, then writes up to LIMIT frames as fast as it can,
printing ``frame N`` (N = frames written) after each, then waits. On ``SIGINT`` it
leaves the ``with`` block through ``KeyboardInterrupt``, prints ``interrupted N`` and
exits with status 130, as a command-line tool would.
"""

from __future__ import annotations

import signal
import sys
import time

import numpy as np

from motes.io.frames import open_writer

HEIGHT, WIDTH = 480, 640


def main(argv: list[str]) -> int:
    output, limit = argv[1], int(argv[2])
    # A process started in the background may inherit SIGINT ignored; this test needs
    # Python's usual Ctrl-C behaviour.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    # Large frames, made in advance: the loop is almost all write(), the pipe to ffmpeg
    # stays full, and the signal nearly always lands while a frame is half handed over.
    yy, xx = np.mgrid[0:HEIGHT, 0:WIDTH]
    frames = [
        (np.stack([xx + 40 * k, yy, np.full_like(xx, 128)], axis=-1) % 256).astype(np.uint8)
        for k in range(4)
    ]
    writer = open_writer(output, fps=30)
    try:
        with writer:
            print("ready", flush=True)
            for k in range(limit):
                writer.write(frames[k % len(frames)])
                print(f"frame {writer.frames_written}", flush=True)
            while True:
                time.sleep(0.01)
    except KeyboardInterrupt:
        print(f"interrupted {writer.frames_written}", flush=True)
        return 130
    return 0  # pragma: no cover - only an interrupt ends the loop


if __name__ == "__main__":
    sys.exit(main(sys.argv))
