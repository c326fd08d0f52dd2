"""The live viewer's server: it starts, serves, obeys its controls, reports and stops."""

from __future__ import annotations

import asyncio
import socket
import threading
import time
import urllib.request

import numpy as np
import pytest

pytest.importorskip("viser")

from motes.cli.main import main
from motes.view.packet import capacity, fits
from motes.view.server import Viewer, ViewError, check_port
from motes.view.sources import CacheSource, LiveSource
from test_view import SCENE


@pytest.fixture
def scene_file(tmp_path):
    path = tmp_path / "spray.toml"
    path.write_text(SCENE)
    return path


@pytest.fixture
def viewer(scene_file):
    source = LiveSource(scene_file)
    source.restart()
    lines: list[str] = []
    served = Viewer(source, port=0, log=lines.append)
    served.lines = lines
    yield served
    served.stop()


def test_it_serves_the_page_on_a_free_port_and_stops_cleanly(viewer):
    page = urllib.request.urlopen(viewer.url, timeout=10).read().decode()
    assert "<html" in page.lower()
    viewer.start()
    deadline = time.monotonic() + 20
    while viewer.shown < 3 and time.monotonic() < deadline:
        time.sleep(0.05)
    assert viewer.shown >= 3  # playing on its own thread
    viewer.stop()
    assert not viewer._thread.is_alive()
    deadline = time.monotonic() + 10
    while True:  # the port is free again (viser closes it on its own thread)
        try:
            assert check_port(viewer.host, viewer.port) == viewer.port
            break
        except ViewError:
            assert time.monotonic() < deadline
            time.sleep(0.1)


def test_a_busy_port_is_named():
    with socket.socket() as holder:
        holder.bind(("127.0.0.1", 0))
        holder.listen()
        port = holder.getsockname()[1]
        with pytest.raises(ViewError, match=rf"port {port} .*busy.*--port"):
            check_port("127.0.0.1", port)


def test_the_controls_step_seek_restart_and_set(viewer, tmp_path):
    viewer.playing = False
    for _ in range(4):
        viewer._do("step")
    assert viewer.shown == 4 == viewer.source.available
    viewer._do("seek", 2)
    assert viewer.shown == 2 and not viewer.playing
    assert viewer._timeline.value == 2 and viewer._timeline.max == 4
    # a value out of range: reported in the panel and the terminal, nothing changed
    key = "system.spray.emitter.0.rate.rate"
    viewer._do("set", key, -1)
    assert key in viewer._error.content and ">= 0" in viewer._error.content
    assert any(key in line for line in viewer.lines)
    assert viewer._controls[key].value == 3000
    viewer._do("set", key, 100)
    assert viewer.source.overrides[key] == 100 and viewer._error.content == ""
    # saved as a scene file, never over another file
    target = tmp_path / "tuned.toml"
    viewer._do("save", str(target))
    assert "rate = 100" in target.read_text()
    other = tmp_path / "mine.toml"
    other.write_text("# mine\n")
    viewer._do("save", str(other))
    assert other.read_text() == "# mine\n" and "exists" in viewer._error.content
    viewer._do("save", str(target))  # our own file of this session: replaced
    viewer._do("restart")
    assert viewer.shown == 0 and viewer.source.available == 0 and viewer.playing


def test_a_diverging_scene_pauses_with_a_message(scene_file):
    from motes.scene import SceneError

    class Diverging(LiveSource):
        def advance(self):
            if self.scene.frame == 3:
                raise SceneError("system.spray", "diverged in frame 4: positions not finite")
            return super().advance()

    source = Diverging(scene_file)
    source.restart()
    lines: list[str] = []
    viewer = Viewer(source, port=0, log=lines.append)
    try:
        viewer.playing = True
        for _ in range(5):
            viewer._tick()
        assert not viewer.playing
        assert "stopped" in viewer._error.content.lower()
        assert any("spray" in line for line in lines)
    finally:
        viewer.stop()


def test_a_scene_file_that_does_not_load_is_shown_and_reloaded(tmp_path):
    from motes.cli.view_command import _source

    path = tmp_path / "broken.toml"
    path.write_text(SCENE.replace("capacity = 5000", "capacity = -5"))

    class Args:
        scene, seed, overrides, history = str(path), None, [], 64

    source, error = _source(Args)
    assert "capacity" in error
    viewer = Viewer(source, port=0, log=lambda line: None, error=error)
    try:
        assert "capacity" in viewer._error.content and not viewer.playing
        path.write_text(SCENE)  # mended: Restart reads the file again
        viewer._do("restart")
        assert viewer._error.content == "" and source.scene is not None
    finally:
        viewer.stop()


def test_view_command_errors(capsys, tmp_path):
    assert main(["view", "no_such_scene_here"]) == 2
    assert "no built-in scene" in capsys.readouterr().err
    assert main(["view", str(tmp_path / "missing.h5")]) == 2
    assert "no such cache" in capsys.readouterr().err
    with socket.socket() as holder:
        holder.bind(("127.0.0.1", 0))
        holder.listen()
        port = holder.getsockname()[1]
        assert main(["view", "fire", "--port", str(port), "--no-browser"]) == 2
        assert f"port {port}" in capsys.readouterr().err


def test_a_cache_plays_back(tmp_path, scene_file):
    cache = tmp_path / "spray.h5"
    assert main(["run", str(scene_file), "--no-render", "--export", str(cache), "-q",
                 "--frames", "6"]) == 0  # fmt: skip
    from motes.cli.view_command import _cache_source

    class Args:
        overrides, seed = [], None

    source = _cache_source(Args, cache)
    assert isinstance(source, CacheSource) and source.available == 6
    # a scene file's path is not recorded: drawn from the entries alone
    packet = source.packet(6)
    from motes.io.cache import load_cache

    state = load_cache(cache).state(5, "spray")
    points = next(iter(packet.points.values()))
    assert len(points.offsets) == state.count
    viewer = Viewer(source, port=0, log=lambda line: None)
    try:
        viewer._do("seek", 4)
        assert viewer.shown == 4
    finally:
        viewer.stop()


def test_the_bytes_sent_are_the_quantized_positions(viewer):
    """A websocket client receives the frame's float16 offsets byte for byte."""
    import viser
    import websockets.asyncio.client

    viewer.playing = False
    viewer._do("step")
    viewer._do("step")
    points = viewer.source.packet(2).points["system.spray/0"]
    wanted = points.offsets.tobytes()
    received = bytearray()

    async def listen():
        uri = f"ws://127.0.0.1:{viewer.port}"
        protocol = f"viser-v{viser.__version__}"
        async with websockets.asyncio.client.connect(
            uri, subprotocols=[protocol], max_size=None
        ) as socket_:
            deadline = time.monotonic() + 10
            while wanted not in received and time.monotonic() < deadline:
                try:
                    message = await asyncio.wait_for(socket_.recv(), timeout=1.0)
                except TimeoutError:
                    continue
                if isinstance(message, bytes):
                    received.extend(message)

    thread = threading.Thread(target=lambda: asyncio.run(listen()))
    thread.start()
    thread.join(timeout=20)
    assert wanted in received
    assert np.frombuffer(wanted, np.float16).shape == (points.offsets.size,)


def test_a_cloud_is_sized_by_radius_and_updated_in_place(viewer):
    """viser's point size is a radius; a cloud with room for the particles is kept."""
    viewer.playing = False
    for _ in range(20):
        viewer._do("step")
    node = "/frame/system.spray/0"
    handle = viewer._nodes[node]
    points = viewer.source.packet(viewer.shown).points["system.spray/0"]
    assert handle.point_size == pytest.approx(0.5 * points.size)
    assert len(handle.points) == capacity(len(points.offsets))
    kept = 0
    for _ in range(6):
        held = len(handle.points)
        viewer._do("step")
        count = len(viewer.source.packet(viewer.shown).points["system.spray/0"].offsets)
        kept += viewer._nodes[node] is handle and fits(count, held)
        handle = viewer._nodes[node]
    assert kept >= 4  # 100 births a frame on about 600: mostly in place


def test_stopping_drops_a_browser_that_does_not_read(viewer):
    """A page too busy to answer would hold viser's polite close for seconds: the
    viewer aborts the connection instead."""
    import viser
    import websockets.sync.client

    viewer.start()
    client = websockets.sync.client.connect(
        f"ws://127.0.0.1:{viewer.port}", subprotocols=[f"viser-v{viser.__version__}"],
        max_size=None,
    )  # fmt: skip
    served = viewer.server._websock_server
    deadline = time.monotonic() + 10
    while not served._live_connections and time.monotonic() < deadline:
        time.sleep(0.05)
    assert served._live_connections  # connected, reading nothing
    viewer._drop_connections()
    deadline = time.monotonic() + 5
    while served._live_connections and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not served._live_connections  # aborted, not waiting on the page
    client.close()
