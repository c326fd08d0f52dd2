"""Helpers shared by the benchmarks: timing, the machine, memory bandwidth, tables."""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numba
import numpy as np

from motes._jit import block_bounds, block_count, parallel_kernel


@dataclass(frozen=True)
class Timing:
    """Wall times [s] of repeated calls: the best and the median."""

    best: float
    median: float


def time_calls(step: Callable[[], object], *, repeat: int, warmup: int = 1) -> Timing:
    """Time ``repeat`` calls of ``step`` after ``warmup`` untimed calls.

    The warm-up calls absorb first-call costs (Numba compilation or cache loading, page
    faults on fresh buffers). The best time is the headline figure: on a small shared
    machine another process can take a core for a whole scheduler time slice, and a
    parallel kernel then waits for its slowest thread, so slow outliers measure the
    neighbours, not the code. The median is reported beside it.
    """
    for _ in range(warmup):
        step()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        step()
        times.append(time.perf_counter() - start)
    return Timing(min(times), statistics.median(times))


def machine() -> dict:
    """Cores, Numba threads and library versions of this machine."""
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        usable = os.cpu_count() or 1
    return {
        "cpu_count": os.cpu_count() or 1,
        "usable_cores": usable,
        "numba_threads": numba.get_num_threads(),
        "background_busy_cores": background_busy_cores(),
        "numba_threading_layer": _threading_layer(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "numba": numba.__version__,
        "processor": platform.processor() or platform.machine(),
    }


class OtherLoad:
    """Cores used on average by *other* processes since construction (Linux).

    A busy machine delays the threads of parallel kernels (a kernel waits for its
    slowest thread, and a thread that lost its core waits a whole scheduler time
    slice), so the figures are reported with this. It is the machine's busy time from
    ``/proc/stat`` (including time stolen by a hypervisor) minus the CPU time of this
    process and of the children it waited for (a benchmark's own ``motes`` runs), over
    the wall time. NaN where ``/proc/stat`` does not exist.
    """

    def __init__(self):
        self._start = self._sample()

    @staticmethod
    def _sample() -> tuple[float, float, float] | None:
        try:
            with open("/proc/stat") as stat:
                ticks = [int(x) for x in stat.readline().split()[1:]]
        except OSError:
            return None
        busy = sum(ticks[:8]) - ticks[3] - ticks[4]  # all but idle and iowait
        own = os.times()
        spent = own.user + own.system + own.children_user + own.children_system
        return busy / os.sysconf("SC_CLK_TCK"), spent, time.perf_counter()

    def cores(self) -> float:
        end = self._sample()
        if end is None or self._start is None:
            return float("nan")
        busy, own, wall = (b - a for a, b in zip(self._start, end, strict=True))
        return max(busy - own, 0.0) / max(wall, 1e-9)


def background_busy_cores(seconds: float = 0.5) -> float:
    """Cores kept busy by other processes while this one sleeps for ``seconds``."""
    load = OtherLoad()
    time.sleep(seconds)
    return load.cores()


def _threading_layer() -> str:
    try:
        return numba.threading_layer()
    except ValueError:  # no parallel kernel has run yet
        return "not yet chosen"


def copy_bandwidth(rows: int, columns: int, *, threads: int = 1, repeat: int = 5) -> float:
    """Memory bandwidth [B/s] of a large ``np.copyto``, counting read + write bytes.

    Copies a ``(rows, columns)`` float32 array, split by rows over ``threads`` threads
    (NumPy releases the GIL while copying); each copy moves ``2 * nbytes`` (read the
    source, write the destination). The best of ``repeat`` copies is the attainable
    streaming rate. One thread may not saturate the memory system where a parallel
    kernel can: measure with as many threads as the kernels use.
    """
    src = np.random.default_rng(0).random((rows, columns), dtype=np.float32)
    dst = np.empty_like(src)
    parts = [slice(p[0], p[-1] + 1) for p in np.array_split(np.arange(rows), threads) if p.size]
    best = math.inf
    with ThreadPoolExecutor(len(parts)) as pool:

        def copy() -> None:
            for done in [pool.submit(np.copyto, dst[p], src[p]) for p in parts]:
                done.result()

        copy()  # fault the destination's pages in before timing
        for _ in range(repeat):
            start = time.perf_counter()
            copy()
            best = min(best, time.perf_counter() - start)
    return 2 * src.nbytes / best


@parallel_kernel
def _triad(a, b, c, scalar):
    for block in numba.prange(block_count(a.shape[0])):
        start, stop = block_bounds(block, a.shape[0])
        for i in range(start, stop):
            a[i] = b[i] + scalar * c[i]


@parallel_kernel
def _update(a, b, scalar):
    for block in numba.prange(block_count(a.shape[0])):
        start, stop = block_bounds(block, a.shape[0])
        for i in range(start, stop):
            a[i] = a[i] + scalar * b[i]


def stream_bandwidth(n: int, *, repeat: int = 5) -> dict[str, float]:
    """Memory bandwidth [B/s] of two compiled STREAM-style kernels over ``n`` float32.

    ``"triad"`` is STREAM's ``a = b + s * c``; ``"update"`` is ``a = a + s * b``, which
    writes back what it read, as the particle kernels do (a store to a line not read
    first also reads it into the cache, traffic the triad pays and the bytes do not
    count). Both run on every Numba thread, as the kernels they bound do, over arrays
    that should be larger than the caches (STREAM asks for four times the last-level
    cache each). Bytes are counted as STREAM counts them: what the loop reads and writes,
    12 bytes a value for both. The best of ``repeat`` runs, after one that compiles and
    faults pages in.
    """
    rng = np.random.default_rng(0)
    b = rng.random(n, dtype=np.float32)
    c = rng.random(n, dtype=np.float32)
    a = np.empty_like(b)
    scalar = np.float32(1e-7)  # the update's values stay finite over any repeat
    runs = {"triad": lambda: _triad(a, b, c, scalar), "update": lambda: _update(a, b, scalar)}
    rates = {}
    for name, run in runs.items():
        run()
        best = math.inf
        for _ in range(repeat):
            start = time.perf_counter()
            run()
            best = min(best, time.perf_counter() - start)
        rates[name] = 12 * n / best
    return rates


def table(rows: list[tuple[str, str]], *, title: str) -> str:
    """A two-column text table with a title line."""
    width = max(len(name) for name, _ in rows)
    lines = [title, "-" * len(title)]
    lines += [f"  {name:<{width}}  {value}" for name, value in rows]
    return "\n".join(lines)


def run_and_report(run: Callable[[], dict]) -> dict:
    """Run a benchmark, add its duration and the load of other processes, and print the
    closing line and the one line of JSON every benchmark ends with.

    Non-finite figures are an error; load figures that cannot be measured (no
    ``/proc/stat``) are reported as ``None``.
    """
    started = time.perf_counter()
    others = OtherLoad()
    figures = run()
    figures["benchmark_seconds"] = time.perf_counter() - started
    figures["other_busy_cores_during_run"] = others.cores()
    for key in ("background_busy_cores", "other_busy_cores_during_run"):
        if not math.isfinite(figures[key]):  # no /proc/stat: unknown, not an error
            figures[key] = None
    bad = [k for k, v in figures.items() if isinstance(v, float) and not math.isfinite(v)]
    if bad:
        raise RuntimeError(f"non-finite figures: {bad}")
    load = figures["other_busy_cores_during_run"]
    note = "unknown" if load is None else f"{load:.2f}"
    if load is not None and load > 0.1:
        note += " (timings inflated: rerun on a quiet machine)"
    print(
        f"\ntotal {figures['benchmark_seconds']:.1f} s; cores kept busy by other processes, "
        f"on average during the run: {note}; the JSON figures follow"
    )
    sys.stdout.flush()
    print(json.dumps(figures, sort_keys=True))
    return figures


def benchmark_main(argv, *, prog: str, doc: str, quick_help: str, run: Callable[[bool], dict]):
    """The command line every benchmark shares: ``--quick``, then :func:`run_and_report`.

    ``run(quick)`` measures and returns the figures; ``doc``'s first paragraph describes
    the benchmark in ``--help``.
    """
    parser = argparse.ArgumentParser(prog=prog, description=doc.split("\n\n")[0])
    parser.add_argument(
        "--quick",
        action="store_true",
        help=f"shrunk sizes ({quick_help}): finishes in seconds; JSON keys keep their "
        "full-size names",
    )
    args = parser.parse_args(argv)
    return run_and_report(lambda: run(args.quick))
