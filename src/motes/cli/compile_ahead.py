"""Compile the drawing kernels in a second process while the first frame is simulated.

On a first run every compiled kernel is built before it is used, one after another:
the fire's first frame waits about 10 s for the simulation's kernels and 28 s for the
drawing's. The two sets do not depend on each other, and compiling is single-threaded,
so on a machine with two or more cores ``motes run`` starts a helper process that loads
the same scene and draws its frame 0 in linear light (the scene as loaded, before any
step: its geometry, shadows and background) while the main process simulates frame 1.
Before drawing frame 1 the main process draws that frame's particles alone, with the
scene's bloom and tone curve (their kernels), waits for the helper, and takes the
kernels it compiled into its own cache; drawing frame 1 then compiles only what is
left.

The helper writes into a cache folder of its own, and its files are copied into the
main process's kernel cache only after it has exited, from the main process's thread,
between two compilations: no two processes ever write one cache entry at once (Numba's
cache has no lock across processes). A kernel the main process has already cached is
left alone. Cached kernels compute the same bits as freshly compiled ones
(:data:`motes._jit.FASTMATH`), so the frames do not depend on which process compiled
what.

The helper runs only when it can help: rendering, at least two usable cores, 1 GB of
memory available (``MOTES_MEMORY_LIMIT`` counts), and an empty cache for the
tone-mapping kernel every rendered frame uses (the sign of a first run).
``MOTES_COMPILE_AHEAD=0`` turns it off.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

#: Environment variable that turns the helper off when set to ``0``.
SWITCH = "MOTES_COMPILE_AHEAD"
#: Longest wait [s] for the helper before frame 1 is drawn without it.
WAIT_S = 600.0
#: Memory [bytes] that must be available to start the helper: it peaks at about 0.3 GB
#: while compiling (the fire at 1280 × 720), and the main process keeps its own needs.
HELPER_MEMORY = 1 << 30


def _usable_cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _memory_for_helper() -> bool:
    from .._memory import available

    found = available()
    return found is None or found[0] >= HELPER_MEMORY


def _numba_caches() -> bool:
    """Whether kernels are compiled and cached the usual way (no override in force)."""
    from numba.core import config

    return not (config.DISABLE_JIT or getattr(config, "CACHE_LOCATOR_CLASSES", ""))


def kernels_cached() -> bool:
    """Whether the tone-mapping kernel has an index in this process's kernel cache; if
    not, this is a first run (an index left by other sources of motes counts as cached:
    no helper then). Ask before the first frame is tone mapped."""
    from ..render.tonemap import _tonemap_kernel

    try:
        return Path(_tonemap_kernel._cache._cache_file._index_path).exists()
    except AttributeError:  # a Numba without this layout: do not guess
        return True


class CompileAhead:
    """The helper process and its private kernel cache (see the module docstring)."""

    def __init__(self, process: subprocess.Popen, folder: Path):
        self.process = process
        self.folder = folder

    @classmethod
    def start(
        cls, scene: str, *, seed, overrides, resolution, check_finite, first_run: bool
    ) -> CompileAhead | None:
        """Start the helper for ``scene`` (the arguments of ``motes run``), or return
        None when it would not help (see the module docstring). ``first_run``: what
        :func:`kernels_cached` said before anything was compiled."""
        if not first_run or os.environ.get(SWITCH, "1") == "0" or _usable_cores() < 2:
            return None
        if not _numba_caches() or not _memory_for_helper():
            return None
        try:
            folder = Path(tempfile.mkdtemp(prefix="motes-kernels-"))
        except OSError:  # no writable temporary folder: compile here, as without it
            return None
        command = [
            sys.executable,
            "-m",
            __name__,
            scene,
            "--resolution",
            "x".join(map(str, resolution)),
        ]
        if seed is not None:
            command += ["--seed", str(seed)]
        for text in overrides:
            command += ["--set", text]
        if not check_finite:
            command.append("--no-check-finite")
        environment = {**os.environ, "NUMBA_CACHE_DIR": str(folder), SWITCH: "0"}
        try:
            process = subprocess.Popen(
                command, env=environment, stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            )  # fmt: skip
        except OSError:
            shutil.rmtree(folder, ignore_errors=True)
            return None
        return cls(process, folder)

    def finish(self, meanwhile: Callable[[], object] | None = None) -> int:
        """Run ``meanwhile`` if the helper is still busy, wait for it, take its kernels
        into this process's cache and remove its folder. Returns the cache files
        copied (0 if the helper failed: this process then compiles what it needs)."""
        try:
            if meanwhile is not None and self.process.poll() is None:
                meanwhile()
            try:
                status = self.process.wait(timeout=WAIT_S)
            except subprocess.TimeoutExpired:
                return 0
            if status != 0:
                return 0
            try:
                return adopt(self.folder)
            except OSError:  # a cache folder that cannot be written: compile here
                return 0
        finally:
            self.close()

    def close(self) -> None:
        """Stop the helper if it still runs and remove its folder (idempotent)."""
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait()
        shutil.rmtree(self.folder, ignore_errors=True)


def adopt(folder: Path) -> int:
    """Copy the kernel cache written under ``folder`` (a ``NUMBA_CACHE_DIR``) into the
    cache this process uses for the same source files; returns the files copied.

    A Numba cache folder holds, per compiled function, an index ``NAME.nbi`` and data
    files ``NAME.K.nbc`` that the index names. Functions this process has already
    cached (its index exists) are skipped; for the others the data files are copied
    before the index, each through a temporary file renamed into place, so a reader
    never finds an index without its data.
    """
    sources = _source_folders()
    copied = 0
    for sub in sorted(p for p in folder.iterdir() if p.is_dir()):
        source = sources.get(sub.name)
        target = _cache_folder(source) if source is not None else None
        if target is None:
            continue
        for index in sorted(sub.glob("*.nbi")):
            name = index.name[: -len(".nbi")]
            if (target / index.name).exists():
                continue
            for data in sorted(sub.glob(f"{glob_escape(name)}.*.nbc")):
                _copy(data, target / data.name)
                copied += 1
            _copy(index, target / index.name)
            copied += 1
    return copied


def glob_escape(text: str) -> str:
    """``text`` with glob's special characters taken literally."""
    return "".join(f"[{c}]" if c in "*?[" else c for c in text)


def _copy(source: Path, target: Path) -> None:
    partial = target.with_name(f"{target.name}.{os.getpid()}.partial")
    shutil.copyfile(source, partial)
    os.replace(partial, target)


def _source_folders() -> dict[str, Path]:
    """motes' source folders by the name Numba gives their cache folder under
    ``NUMBA_CACHE_DIR`` (the folder's name and the SHA-1 of its absolute path)."""
    root = Path(__file__).resolve().parent.parent
    folders = {}
    for path in [root, *(p for p in root.rglob("*") if p.is_dir())]:
        absolute = os.path.abspath(path)
        digest = hashlib.sha1(absolute.encode()).hexdigest()
        folders[f"{os.path.basename(absolute)}_{digest}"] = Path(absolute)
    return folders


def _cache_folder(source: Path) -> Path | None:
    """The folder where this process's Numba caches functions of ``source``'s files
    (the first of Numba's locators that accepts them), or None."""
    from numba.core import caching

    # CacheImpl in recent Numba releases, _CacheImpl in older ones.
    implementation = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    files = sorted(source.glob("*.py"))
    if implementation is None or not files:
        return None
    for locator_class in implementation._locator_classes:
        locator = locator_class.from_function(_cache_folder, str(files[0]))
        if locator is not None:
            return Path(locator.get_cache_path())
    return None


def main(argv: list[str] | None = None) -> int:
    """The helper: load the scene and draw its frame 0 in linear light (nothing is
    written)."""
    from ..scene import load_scene
    from ..scene.overrides import parse_assignment
    from .common import resolution

    parser = argparse.ArgumentParser(prog="python -m motes.cli.compile_ahead")
    parser.add_argument("scene")
    parser.add_argument("--resolution", type=resolution, required=True)
    parser.add_argument("--seed", type=int)
    parser.add_argument("--set", action="append", default=[], dest="overrides")
    parser.add_argument("--no-check-finite", action="store_false", dest="check_finite")
    args = parser.parse_args(argv)
    overrides = dict(parse_assignment(text) for text in args.overrides)
    scene = load_scene(
        args.scene, seed=args.seed, overrides=overrides, check_finite=args.check_finite
    )
    # In linear light: the main process compiles the tone curve (its particle frame).
    scene.renderer(args.resolution).render_scene_hdr(scene)
    return 0


if __name__ == "__main__":
    sys.exit(main())
