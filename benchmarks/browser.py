"""``motes view`` in headless Chromium, driven over the Chrome DevTools Protocol (CDP).

Shared by ``tests/test_view_browser.py`` and ``python -m benchmarks.view``. Three parts,
each a context manager that always stops what it started:

- :class:`ViewerProcess`: ``motes view SCENE --no-browser --port 0`` as a subprocess;
- :class:`HeadlessChromium`: Chromium with software WebGL (SwiftShader) and a DevTools
  port, in a throw-away profile;
- :class:`DevTools`: a CDP connection to its page over a websocket (``websockets``,
  which viser installs), keeping the page's console messages and errors.

:data:`PAGE_COUNTERS` is injected before the page's own scripts: it counts animation
frames, the animation frames in which WebGL drew, and the viewer's frames as they
arrive. viser receives its websocket in a Web Worker, which a page script cannot patch,
so the frames are counted where the worker hands each websocket message (its buffer
transferred whole) to the page.
"""

from __future__ import annotations

import base64
import contextlib
import io
import itertools
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

import numpy as np

#: Chromium's flags: headless, WebGL on SwiftShader (no GPU here), one 1280 x 720 window,
#: and no throttling of a page that never has focus.
CHROMIUM_FLAGS = (
    "--headless=new",
    "--no-sandbox",  # needed when running as root, as in containers
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--window-size=1280,720",
    "--remote-debugging-port=0",
    "--no-first-run",
    "--no-default-browser-check",
    "--disable-extensions",
    "--mute-audio",
    "--disable-background-timer-throttling",
    "--disable-renderer-backgrounding",
    "--disable-backgrounding-occluded-windows",
)

#: Counters the page keeps in ``window.__motes``: ``animationFrames`` (requestAnimationFrame
#: callbacks), ``drawnFrames`` (those after which WebGL had drawn: viser renders on demand,
#: so an idle page has animation frames without drawing), ``batches`` (websocket messages
#: the worker passed on), ``frames`` and ``bytes`` (those carrying binary arrays, i.e.
#: point clouds, and their whole websocket message's size [B]), ``types``: messages by
#: viser's message type (``PointCloudMessage`` creates a point cloud anew), and ``status``:
#: the newest status text received for the panel (the page shows it at its next
#: animation frame, which can be many seconds later when drawing is slow).
PAGE_COUNTERS = """
(() => {
  const stats = {animationFrames: 0, drawnFrames: 0, batches: 0, frames: 0, bytes: 0,
                 types: {}, status: ""};
  window.__motes = stats;
  let drew = false;
  for (const gl of [WebGLRenderingContext, WebGL2RenderingContext]) {
    for (const name of ["drawArrays", "drawElements", "drawArraysInstanced",
                        "drawElementsInstanced", "drawRangeElements"]) {
      const draw = gl.prototype[name];
      if (draw) gl.prototype[name] = function (...args) {
        drew = true;
        return draw.apply(this, args);
      };
    }
  }
  const tick = () => {
    stats.animationFrames += 1;
    if (drew) stats.drawnFrames += 1;
    drew = false;
    requestAnimationFrame(tick);
  };
  requestAnimationFrame(tick);
  // The views of a batch's arrays all share the websocket message's buffer.
  const bufferOf = (value, depth) => {
    if (ArrayBuffer.isView(value)) return value.buffer;
    if (depth === 0 || value === null || typeof value !== "object") return null;
    for (const key in value) {
      const found = bufferOf(value[key], depth - 1);
      if (found) return found;
    }
    return null;
  };
  const NativeWorker = window.Worker;
  window.Worker = class extends NativeWorker {
    constructor(...args) {
      super(...args);
      this.addEventListener("message", (event) => {
        if (!event.data || event.data.type !== "message_batch") return;
        stats.batches += 1;
        for (const message of event.data.messages) {
          stats.types[message.type] = (stats.types[message.type] || 0) + 1;
          for (const value of Object.values(message.updates || {})) {  // markdown text
            if (typeof value === "string" && value.includes(" particles · shown ")) {
              stats.status = value;
            }
          }
        }
        const buffer = bufferOf(event.data.messages, 4);
        if (buffer) {
          stats.frames += 1;
          stats.bytes += buffer.byteLength;
        }
      });
    }
  };
})();
"""


def find_chromium() -> str | None:
    """Path of a Chromium binary on ``PATH`` (``chromium`` or ``chromium-browser``)."""
    return shutil.which("chromium") or shutil.which("chromium-browser")


def _tail(path: Path, lines: int = 20) -> str:
    try:
        return "\n".join(path.read_text(errors="replace").splitlines()[-lines:])
    except OSError:
        return ""


def _wait_for(check, *, timeout: float, what: str, interval: float = 0.1):
    """``check()``'s first truthy value, polled every ``interval`` [s]; TimeoutError
    naming ``what`` after ``timeout`` [s]."""
    deadline = time.monotonic() + timeout
    while True:
        value = check()
        if value:
            return value
        if time.monotonic() > deadline:
            raise TimeoutError(f"timed out after {timeout:.0f} s waiting for {what}")
        time.sleep(interval)


def _stop(process: subprocess.Popen, *, first: int, timeout: float, dump: bool = False) -> int:
    """Send ``first`` (a signal), wait up to ``timeout`` [s], then kill: the exit status.
    ``dump``: before killing, SIGABRT, which makes a Python run with faulthandler on
    write every thread's stack to its stderr (why it did not stop)."""
    if process.poll() is None:
        process.send_signal(first)
        try:
            process.wait(timeout)
        except subprocess.TimeoutExpired:
            if dump:
                process.send_signal(signal.SIGABRT)
                with contextlib.suppress(subprocess.TimeoutExpired):
                    process.wait(5)
            process.kill()
            process.wait()
    return process.returncode


#: ``python -m motes`` with Ctrl-C restored. A process started where SIGINT is ignored
#: (a pytest-xdist worker ignores it, and the ignoring is inherited) gets no
#: KeyboardInterrupt from Python, so the viewer would never see the Ctrl-C it is sent.
WITH_CTRL_C = (
    "import runpy, signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler); "
    "sys.argv[0] = 'motes'; runpy.run_module('motes', run_name='__main__', alter_sys=True)"
)


class ViewerProcess:
    """``motes view SCENE --no-browser --port 0 [ARGS]`` in a subprocess.

    Its stdout and stderr go to files in ``log_dir`` (a pipe nobody reads could fill
    and block the viewer). Leaving the ``with`` block sends SIGINT (Ctrl-C) and waits;
    :attr:`exit_status` is the status it exited with (killed after ``stop_timeout`` [s]).
    """

    def __init__(self, scene: str, *args: str, log_dir: Path, start_timeout: float = 120.0,
                 stop_timeout: float = 30.0):  # fmt: skip
        self.command = [sys.executable, "-c", WITH_CTRL_C, "view", scene, "--no-browser",
                        "--port", "0", *args]  # fmt: skip
        self.stdout_path = Path(log_dir) / "view.stdout"
        self.stderr_path = Path(log_dir) / "view.stderr"
        self.start_timeout, self.stop_timeout = start_timeout, stop_timeout
        self.url = ""
        self.exit_status: int | None = None
        self._process: subprocess.Popen | None = None

    @property
    def pid(self) -> int:
        return self._process.pid

    def __enter__(self) -> ViewerProcess:
        with open(self.stdout_path, "wb") as out, open(self.stderr_path, "wb") as err:
            env = dict(os.environ, PYTHONFAULTHANDLER="1")  # see _stop
            self._process = subprocess.Popen(self.command, stdout=out, stderr=err, env=env)
        try:
            self.url = _wait_for(self._served_url, timeout=self.start_timeout,
                                 what="the viewer to serve")  # fmt: skip
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def _served_url(self) -> str | None:
        found = re.search(r"serving (http://\S+)", self.stdout_path.read_text(errors="replace"))
        if found:
            return found.group(1)
        if self._process.poll() is not None:
            raise RuntimeError(f"motes view exited ({self._process.returncode}):\n"
                               f"{_tail(self.stderr_path)}")  # fmt: skip
        return None

    def __exit__(self, *exc) -> None:
        self.exit_status = _stop(self._process, first=signal.SIGINT, timeout=self.stop_timeout,
                                 dump=True)  # fmt: skip

    def log(self, lines: int = 20) -> str:
        """The last ``lines`` lines the viewer wrote to stderr."""
        return _tail(self.stderr_path, lines)


class HeadlessChromium:
    """Headless Chromium with a DevTools port, in a temporary profile.

    :attr:`page_socket` is the DevTools websocket URL of its first tab. Leaving the
    ``with`` block terminates it (then kills it) and removes the profile.
    """

    def __init__(self, binary: str, *, flags=CHROMIUM_FLAGS, start_timeout: float = 30.0):
        self.binary, self.flags, self.start_timeout = binary, tuple(flags), start_timeout
        self.page_socket = ""
        self._profile: tempfile.TemporaryDirectory | None = None
        self._process: subprocess.Popen | None = None

    @property
    def pid(self) -> int:
        return self._process.pid

    def __enter__(self) -> HeadlessChromium:
        self._profile = tempfile.TemporaryDirectory(prefix="motes-chromium-")
        profile = Path(self._profile.name)
        self._log = open(profile.parent / f"{profile.name}.log", "wb")
        self._process = subprocess.Popen(
            [self.binary, *self.flags, f"--user-data-dir={profile}", "about:blank"],
            stdout=subprocess.DEVNULL, stderr=self._log,
        )  # fmt: skip
        try:
            port = _wait_for(lambda: self._port(profile), timeout=self.start_timeout,
                             what="Chromium's DevTools port")  # fmt: skip
            self.page_socket = _wait_for(lambda: _page_socket(port), timeout=self.start_timeout,
                                         what="Chromium's first tab")  # fmt: skip
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def _port(self, profile: Path) -> int | None:
        """The port Chromium wrote to ``DevToolsActivePort`` (it picks one for port 0)."""
        if self._process.poll() is not None:
            raise RuntimeError(f"Chromium exited ({self._process.returncode}):\n"
                               f"{_tail(Path(self._log.name))}")  # fmt: skip
        try:
            first = (profile / "DevToolsActivePort").read_text().split("\n")[0]
        except OSError:
            return None
        return int(first) if first.strip().isdigit() else None

    def __exit__(self, *exc) -> None:
        try:
            if self._process is not None:
                children = {pid: _started(pid) for pid in descendants(self.pid)[1:]}
                _stop(self._process, first=signal.SIGTERM, timeout=10)
                _reap(children, timeout=5)
        finally:
            self._log.close()
            os.unlink(self._log.name)
            self._profile.cleanup()

    def process_ids(self) -> list[int]:
        """Chromium's processes: the browser and its descendants (GPU, renderers...)."""
        return descendants(self.pid)


def _reap(children: dict[int, int | None], *, timeout: float) -> None:
    """Wait up to ``timeout`` [s] for a stopped browser's children (pid: start time),
    which exit after it; kill those still running."""
    deadline = time.monotonic() + timeout
    alive = dict(children)
    while alive and time.monotonic() < deadline:
        time.sleep(0.05)
        alive = {pid: start for pid, start in alive.items() if _running(pid, start)}
    for pid in alive:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)


def _stat(pid: int) -> list[str] | None:
    """The fields of ``/proc/PID/stat`` after the command name (None if gone)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None


def _started(pid: int) -> int | None:
    """The process's start time [clock ticks after boot]: with the pid, its identity."""
    fields = _stat(pid)
    return None if fields is None else int(fields[19])


def _running(pid: int, started: int | None) -> bool:
    """Whether the process that started at ``started`` still runs (not a zombie, and
    its pid not reused by another process)."""
    fields = _stat(pid)
    return fields is not None and fields[0] != "Z" and int(fields[19]) == started


def _page_socket(port: int) -> str | None:
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=5) as reply:
        targets = json.load(reply)
    pages = [t["webSocketDebuggerUrl"] for t in targets if t.get("type") == "page"]
    return pages[0] if pages else None


class DevTools:
    """A CDP connection to one page: :meth:`call` sends a command and waits for its reply.

    A reader thread takes every message: replies wake their caller; the page's console
    messages, uncaught exceptions and log entries (and those of its workers, attached
    as they start) are kept in :attr:`console` as ``"level: text"`` lines.
    """

    CONSOLE_EVENTS = ("Runtime.consoleAPICalled", "Runtime.exceptionThrown", "Log.entryAdded")

    def __init__(self, socket_url: str, *, timeout: float = 30.0):
        from websockets.sync.client import connect

        # A screenshot arrives as one message of a few MB: no size limit.
        self._socket = connect(socket_url, max_size=None, open_timeout=timeout)
        self.timeout = timeout
        self.console: list[str] = []
        self._ids = itertools.count(1)
        self._replies: dict[int, dict] = {}
        self._arrived = threading.Condition()
        self._reader = threading.Thread(target=self._read, name="cdp-reader", daemon=True)
        self._reader.start()

    def __enter__(self) -> DevTools:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        self._socket.close()
        self._reader.join(timeout=5)

    def send(self, method: str, *, session: str | None = None, **params) -> int:
        """Send a command without waiting: its id."""
        ident = next(self._ids)
        message = {"id": ident, "method": method, "params": params}
        if session is not None:
            message["sessionId"] = session
        self._socket.send(json.dumps(message))
        return ident

    def call(self, method: str, *, reply_within: float | None = None, **params) -> dict:
        """Send a command to the page and wait up to ``reply_within`` [s] (default
        :attr:`timeout`) for its result; RuntimeError on an error."""
        ident = self.send(method, **params)
        limit = self.timeout if reply_within is None else reply_within
        with self._arrived:
            if not self._arrived.wait_for(lambda: ident in self._replies, limit):
                raise TimeoutError(f"no reply to {method} within {limit:.0f} s")
            reply = self._replies.pop(ident)
        if "error" in reply:
            raise RuntimeError(f"{method}: {reply['error'].get('message', reply['error'])}")
        return reply.get("result", {})

    def evaluate(self, expression: str):
        """The value of a JavaScript expression in the page (awaited if a promise)."""
        result = self.call("Runtime.evaluate", expression=expression, returnByValue=True,
                           awaitPromise=True)  # fmt: skip
        if "exceptionDetails" in result:
            raise RuntimeError(f"{expression!r} threw: {result['exceptionDetails']}")
        return result["result"].get("value")

    def _read(self) -> None:
        from websockets.exceptions import ConnectionClosed

        try:
            for raw in self._socket:
                message = json.loads(raw)
                if "id" in message and "sessionId" not in message:
                    with self._arrived:
                        self._replies[message["id"]] = message
                        self._arrived.notify_all()
                else:
                    self._event(message)
        except ConnectionClosed:  # the browser went away: callers time out
            pass

    def _event(self, message: dict) -> None:
        method, params = message.get("method"), message.get("params", {})
        if method == "Target.attachedToTarget":  # a worker: its console too
            session = params["sessionId"]
            self.send("Runtime.enable", session=session)
            self.send("Runtime.runIfWaitingForDebugger", session=session)
        elif method in self.CONSOLE_EVENTS:
            self.console.append(_console_line(method, params))


def _console_line(method: str, params: dict) -> str:
    if method == "Runtime.consoleAPICalled":
        text = " ".join(str(a.get("value", a.get("description", a.get("type"))))
                        for a in params.get("args", []))  # fmt: skip
        return f"{params.get('type', 'log')}: {text}"
    if method == "Runtime.exceptionThrown":
        details = params.get("exceptionDetails", {})
        described = details.get("exception", {}).get("description", details.get("text", ""))
        return f"exception: {described}"
    entry = params.get("entry", {})
    return f"{entry.get('level', 'log')}: {entry.get('text', '')} ({entry.get('url', '')})"


def open_viewer(devtools: DevTools, url: str, *, size: tuple[int, int] = (1280, 720)) -> None:
    """Load the viewer's page in a ``size`` (width, height) [px] viewport, with
    :data:`PAGE_COUNTERS` injected and its consoles watched."""
    for domain in ("Page", "Runtime", "Log"):
        devtools.call(f"{domain}.enable")
    # --window-size includes a window frame headless Chromium draws no page in.
    devtools.call("Emulation.setDeviceMetricsOverride", width=size[0], height=size[1],
                  deviceScaleFactor=1, mobile=False)  # fmt: skip
    devtools.call("Target.setAutoAttach", autoAttach=True, waitForDebuggerOnStart=False,
                  flatten=True)  # fmt: skip
    devtools.call("Page.addScriptToEvaluateOnNewDocument", source=PAGE_COUNTERS)
    devtools.call("Page.navigate", url=url)


def counters(devtools: DevTools) -> dict:
    """:data:`PAGE_COUNTERS` now, with the page's clock ``now`` [ms]."""
    return devtools.evaluate("({...window.__motes, now: performance.now()})")


def page_text(devtools: DevTools) -> str:
    return devtools.evaluate("document.body ? document.body.innerText : ''") or ""


def parse_status(text: str) -> dict | None:
    """The viewer's status lines in the page's text: ``frame``, ``available``,
    ``particles``, ``shown_fps`` and (live scenes) ``simulated_fps``; None before the
    panel shows them."""
    frame = re.search(r"frame (\d+) of (\d+)", text)
    shown = re.search(r"([\d,]+) particles · shown ([\d.]+) fps", text)
    if not (frame and shown):
        return None
    status = {
        "frame": int(frame.group(1)),
        "available": int(frame.group(2)),
        "particles": int(shown.group(1).replace(",", "")),
        "shown_fps": float(shown.group(2)),
    }
    simulated = re.search(r"simulated ([\d.]+) fps", text)
    if simulated:
        status["simulated_fps"] = float(simulated.group(1))
    return status


def shown_status(devtools: DevTools) -> dict | None:
    """The status the page's panel shows (:func:`parse_status`)."""
    return parse_status(page_text(devtools))


def received_status(devtools: DevTools) -> dict | None:
    """The newest status the page received; it shows it at its next animation frame."""
    return parse_status(counters(devtools)["status"])


def wait_for_status(devtools: DevTools, ready, *, timeout: float, what: str,
                    read=shown_status) -> dict:  # fmt: skip
    """The first status (``read(devtools)``) for which ``ready(status)`` holds."""

    def check():
        status = read(devtools)
        return status if status is not None and ready(status) else None

    return _wait_for(check, timeout=timeout, what=what, interval=0.25)


def wait_for_drawing(devtools: DevTools, *, timeout: float = 30.0) -> dict:
    """Wait until WebGL has drawn twice after a new frame of particles arrived (viser
    draws on demand: a frame is on screen once a draw follows it); the counters then."""
    start = counters(devtools)

    def drawn():
        now = counters(devtools)
        fresh = now["frames"] > start["frames"] and now["drawnFrames"] >= start["drawnFrames"] + 2
        return now if fresh else None

    return _wait_for(drawn, timeout=timeout, what="the page to draw a new frame")


def screenshot(devtools: DevTools, *, timeout: float = 60.0) -> bytes:
    """The page as a PNG. It waits for a new frame to be drawn: on software WebGL, seconds
    at a million points; TimeoutError after ``timeout`` [s]."""
    shot = devtools.call("Page.captureScreenshot", format="png", reply_within=timeout)
    return base64.b64decode(shot["data"])


def canvas_box(devtools: DevTools) -> tuple[int, int, int, int]:
    """``(left, top, right, bottom)`` [CSS px] of the page's largest canvas (the 3D view)."""
    box = devtools.evaluate("""(() => {
        const areas = [...document.querySelectorAll("canvas")].map(c => c.getBoundingClientRect());
        const r = areas.sort((a, b) => b.width * b.height - a.width * a.height)[0];
        return r ? [r.left, r.top, r.right, r.bottom] : null;
    })()""")
    if box is None:
        raise RuntimeError("the page has no canvas")
    return tuple(round(v) for v in box)


def pixels(png: bytes) -> np.ndarray:
    """(height, width, 3) uint8 RGB of a PNG."""
    from PIL import Image

    with Image.open(io.BytesIO(png)) as image:
        return np.asarray(image.convert("RGB"))


def descendants(pid: int) -> list[int]:
    """``pid`` and every process below it (Linux ``/proc``; just ``[pid]`` elsewhere)."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").glob("[0-9]*"):
        fields = _stat(int(entry.name))
        if fields is not None:  # None: gone since the listing
            children.setdefault(int(fields[1]), []).append(int(entry.name))
    found, todo = [], [pid]
    while todo:
        current = todo.pop()
        found.append(current)
        todo += children.get(current, [])
    return found


def cpu_seconds(pid: int) -> float:
    """User + system CPU time [s] of one process so far (0 if it is gone)."""
    fields = _stat(pid)
    if fields is None:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def process_kind(pid: int) -> str:
    """A Chromium process's ``--type`` (``gpu-process``, ``renderer``...), ``browser`` for
    the main one, the program's name for others."""
    try:
        command = Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return "gone"
    # Chromium's children rewrite their command line as one space-separated string.
    kind = re.search(rb"--type=([\w-]+)", command)
    if kind:
        return kind.group(1).decode()
    program = Path(command.split(b"\0")[0].split(b" ")[0].decode(errors="replace")).name
    return "browser" if program == "chromium" else program
