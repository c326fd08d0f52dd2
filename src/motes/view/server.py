"""The live viewer: a viser server that shows a :class:`~motes.view.sources.Source`.

viser (a maintained Python library) serves a three.js client over a websocket and
keeps the browser's scene in step with the server's: the viewer only says what to
draw. The simulation runs on one thread of its own; the browser's controls reach it as
commands in a queue, taken between frames, so a frame is never drawn half-changed.
viser drops an update that a newer one replaces before it was sent, so a link slower
than the simulation shows the newest frame, late frames skipped; ``max_points`` thins
big systems by a stride (every k-th particle) to lighten each frame.
"""

from __future__ import annotations

import queue
import socket
import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..finite import NonFiniteError
from ..scene import SceneError
from .packet import FramePacket, capacity, fits, padded
from .params import Parameter
from .sources import LiveSource, Source

__all__ = ["ViewError", "Viewer", "check_port"]

#: Seconds :meth:`Viewer.stop` waits for viser to close its server.
STOP_WAIT = 2.0


class ViewError(RuntimeError):
    """The viewer cannot start (the message says why)."""


def check_port(host: str, port: int) -> int:
    """``port`` if it can be listened on at ``host``; 0 picks a free one. Raises
    :class:`ViewError` naming the port when another program holds it."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        # as the server will: a port left in TIME_WAIT by a closed connection is free
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind((host, port))
        except OSError as error:
            raise ViewError(
                f"port {port} on {host} is busy ({error.strerror}): another program, or "
                "another viewer, listens there; give --port with another number, or "
                "--port 0 for any free port"
            ) from None
        return probe.getsockname()[1]


class Viewer:
    """Serve ``source`` to browsers at ``http://host:port``.

    Parameters
    ----------
    source : Source
        A :class:`~motes.view.sources.LiveSource` (simulated as watched) or a
        :class:`~motes.view.sources.CacheSource`.
    host, port : str, int
        Where to listen; port 0 picks a free one.
    log : callable
        Where messages for the terminal go (one line each).
    error : str, optional
        A scene that failed to load: shown until a reload succeeds.
    """

    def __init__(self, source: Source, *, host: str = "127.0.0.1", port: int = 8080,
                 log: Callable[[str], None] = print, error: str | None = None):  # fmt: skip
        import viser

        port = check_port(host, port)
        self.server = viser.ViserServer(host=host, port=port, label="motes", verbose=False)
        if self.server.get_port() != port:  # taken between the check and viser's bind
            self.server.stop()
            raise ViewError(f"port {port} on {host} is busy; give --port 0 for any free port")
        self.host, self.port = host, port
        self.source = source
        self.log = log
        self.commands: queue.Queue = queue.Queue()
        self.playing = error is None
        self.shown = 0
        self.real_time = True
        self.loop = False
        self._stopped = threading.Event()
        self._thread: threading.Thread | None = None
        self._nodes: dict[str, object] = {}
        self._static: list[object] = []
        self._controls: dict[str, object] = {}
        self._param_folders: list[object] = []
        self._step_seconds = 0.0  # simulation time of the latest frame [s]
        self._shown_at: list[float] = []  # wall times of recent frames shown
        self._clients = 0
        self._was_playing = False
        self._status_at = 0.0
        self._counts: dict[str, int] = {}
        self._build_gui()
        self.server.scene.set_up_direction("+y")
        self.server.on_client_connect(self._connected)
        self.server.on_client_disconnect(self._disconnected)
        if error is not None:
            self._report("The scene did not load", error)
        else:
            self._started()

    @property
    def url(self) -> str:
        shown = "localhost" if self.host in ("127.0.0.1", "0.0.0.0", "") else self.host
        return f"http://{shown}:{self.port}"

    # -- running -------------------------------------------------------------------
    def start(self) -> None:
        """Run the simulation thread (returns at once; :meth:`stop` ends it)."""
        self._thread = threading.Thread(target=self._run, name="motes-view", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """End the simulation thread and the server."""
        self._stopped.set()
        self.commands.put(("wake",))
        if self._thread is not None:
            self._thread.join(timeout=10)
        self._drop_connections()
        # viser's stop waits up to 6 s for its event loop, which can itself wait on a
        # browser's half-open connection; past STOP_WAIT it goes on in the background
        # (its threads are daemons: they never hold the process up).
        closing = threading.Thread(target=self.server.stop, name="viser-stop", daemon=True)
        closing.start()
        closing.join(STOP_WAIT)

    def _drop_connections(self) -> None:
        """Abort the browsers' connections at once. Closing them politely waits for each
        browser to answer, which a page busy drawing a million points does late: viser
        then waits 6 s before it gives up, and a stopped viewer has nothing more to say.
        (viser has no public call for this: its connections are reached by name.)"""
        served = getattr(self.server, "_websock_server", None)
        loop = getattr(served, "_background_event_loop", None)
        if loop is None or loop.is_closed():
            return
        for connection in tuple(getattr(served, "_live_connections", {}).values()):
            transport = getattr(connection, "transport", None)
            if transport is not None:
                loop.call_soon_threadsafe(transport.abort)

    def _run(self) -> None:
        while not self._stopped.is_set():
            try:
                self._take_commands(block=not self.playing)
                if self.playing and not self._stopped.is_set():
                    self._tick()
            except Exception as error:  # the server outlives any frame: say it, pause
                self.playing = False
                self._report("Stopped", f"{type(error).__name__}: {error}")

    def _take_commands(self, *, block: bool) -> None:
        try:
            command = self.commands.get(timeout=0.25) if block else self.commands.get_nowait()
        except queue.Empty:
            return
        while True:
            self._do(*command)
            try:
                command = self.commands.get_nowait()
            except queue.Empty:
                self._update_status()
                return

    def _tick(self) -> None:
        source = self.source
        start = time.perf_counter()
        if self.shown < source.available:
            packet = self._stored(self.shown + 1)
        elif source.live and not (source.finished and self.loop):
            try:
                packet = source.advance()
            except (SceneError, NonFiniteError) as error:
                self.playing = False
                self._report("The simulation stopped", str(error))
                return
            self._step_seconds = time.perf_counter() - start
        elif self.loop and source.available:
            if source.live:
                self._restart()
                return
            packet = self._stored(source.first)
        else:
            self.playing = False
            self._update_status()
            return
        self._show(packet)
        if self.real_time and source.scene is not None:
            time.sleep(max(0.0, 1.0 / source.scene.fps - (time.perf_counter() - start)))

    def _stored(self, index: int) -> FramePacket:
        """Frame ``index`` from the source; the oldest kept one if it was let go."""
        try:
            return self.source.packet(index)
        except KeyError:
            return self.source.packet(self.source.first)

    # -- commands (from the browser, run on the simulation thread) -----------------
    def _do(self, name: str, *args) -> None:
        if name == "play":
            self.playing = True
        elif name == "pause":
            self.playing = False
            self._update_status()
        elif name == "step":
            self.playing = False
            self._tick()
            self._update_status()
        elif name == "seek":
            self.playing = False
            if self.source.available:
                index = int(np.clip(args[0], self.source.first, self.source.available))
                self._show(self._stored(index))
            self._update_status()
        elif name == "restart":
            self._restart()
        elif name == "set":
            self._set(*args)
        elif name == "save":
            self._save(args[0])
        elif name == "points":
            self.source.max_points = int(args[0])

    def _restart(self) -> None:
        source = self.source
        try:
            if isinstance(source, LiveSource):
                source.restart()
        except (SceneError, OSError) as error:
            self.playing = False
            self._report("The scene did not load", str(error))
            return
        self._started()
        self.playing = True

    def _started(self) -> None:
        """A scene (re)loaded: its objects, its camera, its controls, frame 0."""
        source = self.source
        for handle in [*self._nodes.values(), *self._static]:
            handle.remove()
        self._nodes, self._static, self.shown = {}, [], 0
        self._error.content = ""
        if source.scene is not None:
            self._aim(source.scene.camera)
            static = source.static()
            with self.server.atomic():
                self._static = [self._add(f"/object/{name}", shape)
                                for name, shape in _shapes(static)]  # fmt: skip
        if isinstance(source, LiveSource):
            self._build_parameters(source.parameters)
        if source.available:  # a cache: its first frame
            self._show(self._stored(source.first))
        self._update_status()

    def _set(self, key: str, value) -> None:
        source = self.source
        if not isinstance(source, LiveSource):
            return
        old = next((p.value for p in source.parameters if p.key == key), None)
        try:
            waiting = source.set_values({key: value})
        except SceneError as error:
            self._report(f"{key} not set", str(error))
            control = self._controls.get(key)
            if control is not None and old is not None:
                control.value = old  # back to the value in force (our own set: ignored)
            return
        when = "at restart" if waiting else "from the next step"
        self.log(f"motes view: {key} = {value!r} ({when})")
        self._error.content = ""

    def _save(self, path: str) -> None:
        source = self.source
        if not isinstance(source, LiveSource) or source.scene is None:
            return
        target = Path(path).expanduser()
        try:
            if target.resolve() == Path(str(source.source)).resolve():
                raise OSError("that is the scene file itself: save under another name")
            if target.exists() and target not in self._saved:
                raise OSError(f"{target} exists: give another name (it is not replaced)")
            if target.suffix != ".toml":
                raise OSError(f"a scene file ends in .toml, got {target.name}")
            source.save(target)
        except OSError as error:
            self._report("Not saved", str(error))
            return
        self._saved.add(target)
        self.log(f"motes view: saved {target}")
        self._notify("Saved", f"{target}", color="green")

    # -- drawing -------------------------------------------------------------------
    def _show(self, packet: FramePacket) -> None:
        names = set()
        with self.server.atomic():
            for name, shape in _shapes(packet):
                node = f"/frame/{name}"
                names.add(node)
                self._nodes[node] = self._update(node, shape, self._nodes.get(node))
            for node in [n for n in self._nodes if n not in names]:
                self._nodes.pop(node).remove()
        self.shown = packet.index
        self._counts = packet.counts
        now = time.perf_counter()
        self._shown_at = [t for t in self._shown_at if now - t < 2.0] + [now]
        if now - self._status_at > 0.25:
            self._update_status()

    def _add(self, node: str, shape):
        return self._update(node, shape, None)

    def _update(self, node: str, shape, handle):
        from .packet import Lines, Mesh, Points

        scene = self.server.scene
        if isinstance(shape, Points):
            # viser's point_size is a radius: a point of point_size s at depth z covers
            # s · height / (tan(fov / 2) · z) pixels.
            size = 0.5 * shape.size * self._point_scale.value
            precision = "float16" if shape.offsets.dtype == np.float16 else "float32"
            held = len(handle.points) if handle is not None else 0
            same = handle is not None and handle.precision == precision
            if same and fits(len(shape.offsets), held):
                offsets, colors = padded(shape.offsets, shape.colors, held)
                handle.points = offsets
                handle.colors = colors
                handle.position = shape.origin
                handle.point_size = size
                return handle
            offsets, colors = padded(shape.offsets, shape.colors, capacity(len(shape.offsets)))
            return scene.add_point_cloud(node, offsets, colors, point_size=size,
                                         point_shape="circle", precision=precision,
                                         position=shape.origin)  # fmt: skip
        if isinstance(shape, Mesh):
            if handle is not None and handle.faces.shape == shape.faces.shape:
                handle.vertices = shape.vertices
                return handle
            return scene.add_mesh_simple(node, shape.vertices, shape.faces, color=shape.color,
                                         side="double")  # fmt: skip
        assert isinstance(shape, Lines)
        return scene.add_line_segments(node, shape.segments, shape.colors, thickness=1.5,
                                       thickness_units="screen")  # fmt: skip

    def _aim(self, camera) -> None:
        """Start every browser's view at the scene's camera."""
        initial = self.server.initial_camera
        initial.position = tuple(float(v) for v in camera.position)
        initial.look_at = tuple(float(v) for v in camera.target)
        initial.up = tuple(float(v) for v in camera.up)
        initial.fov = float(np.radians(camera.fov))
        for client in self.server.get_clients().values():
            client.camera.position = initial.position
            client.camera.look_at = initial.look_at

    # -- the panel -----------------------------------------------------------------
    def _build_gui(self) -> None:
        gui = self.server.gui
        gui.configure_theme(dark_mode=True, control_width="large")
        self._saved: set[Path] = set()
        self._status = gui.add_markdown("")
        self._error = gui.add_markdown("")
        with gui.add_folder("Playback"):
            self._play = gui.add_button("Play / pause", hint="space")
            self._step = gui.add_button("Step", hint="one frame")
            self._restart_button = gui.add_button(
                "Restart", hint="from the start, with the values now set (reads the file again)"
            )
            self._timeline = gui.add_slider("Frame", min=0, max=1, step=1, initial_value=0)
            self._real = gui.add_checkbox("Real time", initial_value=True,
                                          hint="at most the scene's frame rate")  # fmt: skip
            self._loop = gui.add_checkbox("Loop", initial_value=False)
        with gui.add_folder("Points", expand_by_default=False):
            self._point_scale = gui.add_slider("Size ×", min=0.1, max=4.0, step=0.1,
                                               initial_value=1.0)  # fmt: skip
            self._max_points = gui.add_number(
                "Sent at most",
                initial_value=self.source.max_points,
                min=1000,
                step=1000,
                hint="particles per frame; more are thinned by a stride (every k-th)",
            )
        self._play.on_click(lambda _: self.commands.put(("pause",) if self.playing else ("play",)))
        self._step.on_click(lambda _: self.commands.put(("step",)))
        self._restart_button.on_click(lambda _: self.commands.put(("restart",)))
        self._timeline.on_update(self._from_browser(lambda v: self.commands.put(("seek", v))))
        self._real.on_update(self._from_browser(lambda v: setattr(self, "real_time", v)))
        self._loop.on_update(self._from_browser(lambda v: setattr(self, "loop", v)))
        self._max_points.on_update(self._from_browser(lambda v: self.commands.put(("points", v))))

    def _from_browser(self, action):
        """A control's callback that acts on values set in the browser only (not the
        viewer's own updates of the control)."""

        def callback(event) -> None:
            if event.client is not None:
                action(event.target.value)

        return callback

    def _build_parameters(self, params: list[Parameter]) -> None:
        gui = self.server.gui
        for folder in self._param_folders:
            folder.remove()
        self._param_folders, self._controls = [], {}
        groups: dict[str, list[Parameter]] = {}
        for p in params:
            groups.setdefault(p.group, []).append(p)
        for group, members in groups.items():
            folder = gui.add_folder(group.capitalize(), expand_by_default=False)
            self._param_folders.append(folder)
            with folder:
                for p in members:
                    self._controls[p.key] = control = _control(gui, p)
                    control.on_update(self._from_browser(
                        lambda v, key=p.key: self.commands.put(("set", key, _plain(v)))
                    ))  # fmt: skip
        if isinstance(self.source, LiveSource):
            with gui.add_folder("Save", expand_by_default=False) as folder:
                self._param_folders.append(folder)
                default = f"{self.source.scene.name}_tuned.toml" if self.source.scene else ""
                path = gui.add_text("Scene file", initial_value=default)
                button = gui.add_button("Save values", hint="a scene file with the values set")
                button.on_click(lambda _: self.commands.put(("save", path.value)))

    def _update_status(self) -> None:
        self._status_at = time.perf_counter()
        source = self.source
        shown = self._shown_at
        rate = (len(shown) - 1) / (shown[-1] - shown[0]) if len(shown) > 1 else 0.0
        particles = sum(self._counts.values())
        scene = source.scene
        name = scene.name if scene is not None else "no scene"
        lines = [f"**{name}** · frame {self.shown} of {source.available}"
                 + (f" (shot: {scene.frame_count})" if scene is not None else "")]  # fmt: skip
        state = "playing" if self.playing else "paused"
        lines.append(f"{state} · {particles:,} particles · shown {rate:.1f} fps")
        if source.live and self._step_seconds > 0:
            lines.append(f"simulated {1.0 / self._step_seconds:.1f} fps")
        self._status.content = "  \n".join(lines)
        self._timeline.max = max(1, source.available)
        self._timeline.min = min(source.first, self._timeline.max)
        self._timeline.value = max(self._timeline.min, self.shown)

    # -- messages ------------------------------------------------------------------
    def _report(self, title: str, message: str) -> None:
        """A problem: in the terminal, in the panel and as a notification."""
        self.log(f"motes view: {title.lower()}: {message}")
        self._error.content = f"**{title}**: {message}"
        self._notify(title, message, color="red")

    def _notify(self, title: str, body: str, *, color: str) -> None:
        for client in self.server.get_clients().values():
            client.add_notification(title, body, auto_close_seconds=8.0, color=color)

    def _connected(self, client) -> None:
        self._clients += 1
        if self._clients == 1 and self._was_playing:
            self.commands.put(("play",))
        self._was_playing = False

    def _disconnected(self, client) -> None:
        self._clients = max(0, self._clients - 1)
        if self._clients == 0 and not self._stopped.is_set():
            self._was_playing = self.playing
            self.commands.put(("pause",))
            self.log(f"motes view: the browser closed; still serving {self.url} (Ctrl-C stops)")


def _shapes(packet: FramePacket):
    """``(name, shape)`` of every shape of ``packet``."""
    yield from packet.points.items()
    yield from packet.meshes.items()
    yield from packet.lines.items()


def _plain(value):
    return tuple(float(v) for v in value) if isinstance(value, tuple) else value


def _control(gui, p: Parameter):
    """The browser control of parameter ``p``: a slider for a number (0 to 4 times its
    value, or the reverse), a field for an integer, fields for 2 or 3 numbers."""
    label = p.label if p.live else f"{p.label} ⟲"
    hint = p.key + ("" if p.live else " (acts at restart)")
    if isinstance(p.value, tuple):
        add = gui.add_vector2 if len(p.value) == 2 else gui.add_vector3
        value = tuple(float(v) for v in p.value)
        return add(label, initial_value=value, step=_step(max(map(abs, value))), hint=hint)
    if p.integer:
        return gui.add_number(label, initial_value=p.value, step=1, hint=hint)
    value = float(p.value)
    low, high = sorted((0.0, 4.0 * value)) if value else (-1.0, 1.0)
    return gui.add_slider(label, min=low, max=high, step=_step(high - low), initial_value=value,
                          hint=hint)  # fmt: skip


def _step(span: float) -> float:
    """A round step of about a thousandth of ``span``."""
    if span <= 0:
        return 0.01
    return float(10.0 ** np.floor(np.log10(span / 1000.0)))
