"""Drawing a cache's frames on a Dask cluster (``motes render CACHE -o DIR --workers N``).

Each frame is one task: a worker loads the cache and the scene once (then keeps them for
the frames it draws next), draws the frame with :class:`~motes.scene.replay.Replay` on
one Numba thread, and writes ``DIR/frame_#####.png`` numbered by the cached frame, under
a temporary name renamed when complete. The frames are therefore those a serial
``motes render`` writes, bit for bit (drawing does not depend on the thread count), and
an interrupted render resumes: frames already in the folder are not drawn again.

Dask's ``distributed`` (an optional extra, ``pip install 'motes[farm]'``) runs the tasks:
a local cluster of ``workers`` processes with one thread each, or an existing cluster at
a scheduler address, whose workers need motes installed and must see the cache's and the
folder's paths.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

from ..io._atomic import replacing
from ..io.frames import SEQUENCE_METADATA, _save_png

#: File name of cached frame ``index`` in the output folder.
FRAME_NAME = "frame_{:05d}.png"


class FarmError(RuntimeError):
    """The cluster could not be used (the message says why)."""


def missing_frames(folder: Path, indices: Sequence[int]) -> list[int]:
    """The frames of ``indices`` whose file is not yet in ``folder`` (a resumed render)."""
    return [i for i in indices if not (folder / FRAME_NAME.format(i)).is_file()]


@contextlib.contextmanager
def dask_client(
    *, workers: int | None = None, scheduler: str | None = None, client=None
) -> Iterator:
    """A ``distributed.Client``: ``client`` itself (left open), one connected to the
    running cluster at ``scheduler``, or one of a local cluster of ``workers``
    single-threaded processes, closed (with its cluster) at the end.

    Raises :class:`FarmError` without ``distributed`` or when the scheduler cannot be
    reached.
    """
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise FarmError(
            "running on Dask needs the distributed package: pip install 'motes[farm]'"
        ) from None
    if client is not None:
        yield client
        return
    cluster = None
    try:
        if scheduler is not None:
            client = Client(scheduler, timeout="10s")
        else:
            cluster = LocalCluster(
                n_workers=workers,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                # the scheduler's small HTTP server (health, metrics) on a free port, not
                # on 8787, which another cluster on this machine may hold
                scheduler_kwargs={"dashboard_address": ":0"},
            )
            client = Client(cluster)
    except OSError as error:
        if cluster is not None:
            cluster.close()
        raise FarmError(f"cannot reach the Dask scheduler {scheduler}: {error}") from None
    try:
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def render_on_dask(
    cache: Path,
    folder: Path,
    indices: Sequence[int],
    *,
    scene: str | None = None,
    overrides: dict | None = None,
    resolution: tuple[int, int] | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    metadata: dict[str, str] | None = None,
    progress: Callable[[int], None] | None = None,
    client=None,
) -> int:
    """Draw cached frames ``indices`` into ``folder`` on Dask; return the frames drawn.

    ``workers`` starts a local cluster of that many single-threaded processes;
    ``scheduler`` (an address such as ``tcp://host:8786``) uses a running one instead.
    ``client`` (a ``distributed.Client``) uses that connection, left open, instead of
    either. Frames already in ``folder`` are skipped. ``progress`` is called with the
    count of frames present after each one finishes. ``metadata`` goes into every PNG and, with
    the frame count, into ``folder/frames.json`` once all are there.
    """
    from distributed import as_completed

    folder.mkdir(parents=True, exist_ok=True)
    todo = missing_frames(folder, indices)
    present = len(indices) - len(todo)
    if progress is not None:
        progress(present)
    options = {
        "cache": str(Path(cache).resolve()),
        "scene": scene,
        "overrides": dict(overrides or {}),
        "resolution": resolution,
        "folder": str(folder.resolve()),
        "metadata": metadata,
    }
    with dask_client(workers=workers, scheduler=scheduler, client=client) as connected:
        futures = connected.map(draw_frame, todo, **options, pure=False)
        for future in as_completed(futures):
            future.result()  # a worker's error is raised here, with its message
            present += 1
            if progress is not None:
                progress(present)
    if metadata:
        record = {**metadata, "frames": len(indices), "prefix": "frame_", "start": indices[0]}
        with replacing(folder / SEQUENCE_METADATA) as tmp:
            Path(tmp).write_text(json.dumps(record, indent=2) + "\n")
    return len(todo)


# One (cache, scene) per worker process, kept between its tasks: loading the scene and
# reading the cache cost more than drawing a small frame.
_replays: dict[tuple, object] = {}


def draw_frame(index, *, cache, scene, resolution, folder, metadata, overrides=None) -> str:
    """Draw cached frame ``index`` into ``folder`` (a task run on a worker)."""
    import numba

    from ..io.cache import load_cache
    from .replay import Replay, load_for

    numba.set_num_threads(1)  # one thread a worker: workers share the cores
    path = Path(cache)
    key = (str(path), path.stat().st_mtime_ns, scene, repr(sorted((overrides or {}).items())))
    replay = _replays.get(key)
    if replay is None:
        loaded = load_cache(path)
        replay = _replays[key] = Replay(load_for(loaded, scene, overrides), loaded)
    target = Path(folder) / FRAME_NAME.format(index)
    _save_png(target, replay.render(index, resolution), metadata)
    return str(target)
