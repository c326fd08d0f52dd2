"""Image and video output: PNG stills and sequences, GIF, H.264 MP4, contact sheets.

A frame is a ``uint8`` array of shape ``(height, width, 3)``: sRGB, rows top to bottom.
:func:`open_writer` picks a writer from the output path:

===================  ===================================================================
path                 writer
===================  ===================================================================
``movie.mp4``        :class:`Mp4Writer`: H.264 (libx264, yuv420p, BT.709), via the
                     ffmpeg binary bundled with ``imageio-ffmpeg``
``loop.gif``         :class:`GifWriter`: an adaptive palette per frame, loops, via the
                     same ffmpeg
``still.png``        :class:`PngWriter`: a single image, the *last* frame written
``frames/``          :class:`SequenceWriter`: ``frame_00000.png``, ``frame_00001.png``, ...
===================  ===================================================================

Interruption
------------
Every writer is made to be stopped at any moment (Ctrl-C, an exception in the
simulation, an error in the writer) and still leave usable output:

- each file is written under a hidden temporary name next to it
  (``.movie.<random>.part.mp4``) and moved into place with :func:`os.replace` only when
  complete, so a reader never sees a half-written file;
- closing a writer, which a ``with`` block does also while an exception propagates,
  finishes the file with every frame written so far: the MP4 gets its index (the
  ``moov`` atom) and is playable, the GIF its trailer, each PNG of a sequence was already
  complete when the next frame began;
- a writer closed before its first frame writes nothing, so an earlier file at the same
  path survives an interrupted run that never got to draw;
- ffmpeg runs in a session of its own, so the Ctrl-C that the terminal sends to the
  whole foreground process group reaches Python only and ffmpeg is still there to
  finish the file when the writer closes;
- :meth:`FrameWriter.write` holds back Ctrl-C (in the main thread) until the frame has
  been handed over completely: a frame is in the output entirely or not at all, and
  :attr:`FrameWriter.frames_written` counts exactly the frames in the output. A second
  Ctrl-C during the same write is obeyed at once.

Metadata
--------
Every writer takes ``metadata``, a dict of text (``motes run`` records the scene's name,
its source, the seed and the motes version), and stores it where the format has room:
PNG text chunks, one per key (``tEXt``, or ``iTXt`` for text beyond Latin-1); a JSON
object in the GIF comment and in the MP4 ``comment`` tag (ffmpeg's ``-metadata``); a
``frames.json`` side file in a PNG sequence folder (given metadata), which also holds
the number of frames (each frame also carries the text chunks). :func:`read_metadata`
reads any of them back.

What is not covered: a process killed outright (``SIGKILL``, an unhandled ``SIGTERM``)
cannot finish anything and leaves the hidden temporary file behind; a Ctrl-C while a
writer is *closing* abandons the new file (its temporary is removed; an earlier file at
the path is kept). A writer that is never closed leaves its temporary file: use
``with`` or call :meth:`~FrameWriter.close` in a ``finally``.

Examples
--------
>>> import numpy as np
>>> from motes.io.frames import open_writer
>>> with open_writer("spark.mp4", fps=30) as out:  # doctest: +SKIP
...     for k in range(60):
...         out.write(np.full((48, 64, 3), 4 * k, dtype=np.uint8))
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import shutil
import subprocess
import tempfile
from abc import ABC, abstractmethod
from collections.abc import Iterable, Sequence
from fractions import Fraction
from pathlib import Path

import numpy as np

from .. import _validate as check
from ._atomic import DeferredInterrupt, discard, replacing, temporary_sibling

#: File suffixes :func:`open_writer` knows (a directory gives a PNG sequence).
SUFFIXES = (".mp4", ".gif", ".png")

#: The side file of a PNG sequence that holds its metadata.
SEQUENCE_METADATA = "frames.json"


def _check_metadata(metadata) -> dict[str, str]:
    """``metadata`` as a dict of str -> str (keys: letters, digits, ``_``, ``-``)."""
    if metadata is None:
        return {}
    if not isinstance(metadata, dict):
        raise TypeError(f"metadata must be a dict of strings, got {type(metadata).__name__}")
    for key, value in metadata.items():
        if (
            not isinstance(key, str)
            or not key.isascii()
            or not key.replace("_", "a").replace("-", "a").isalnum()
        ):
            raise ValueError(
                f"metadata keys must be names of letters, digits, '_', '-', got {key!r}"
            )
        if not isinstance(value, str):
            raise TypeError(f"metadata[{key!r}] must be a string, got {type(value).__name__}")
    return dict(metadata)


def _check_image(
    name: str, image, *, channels: tuple[int, ...] = (3,), dtypes: tuple = (np.uint8,)
) -> np.ndarray:
    """``image`` as a C-contiguous array of shape ``(height, width, c)``, of one of
    ``dtypes`` (``uint8`` unless a writer takes 16 bits too)."""
    if not isinstance(image, np.ndarray):
        raise TypeError(f"{name} must be a NumPy array, got {type(image).__name__}")
    allowed = " or ".join(str(c) for c in channels)
    if image.ndim != 3 or image.shape[2] not in channels or 0 in image.shape:
        raise ValueError(
            f"{name} must have shape (height, width, {allowed}) with height, width >= 1, "
            f"got shape {image.shape}"
        )
    if image.dtype not in dtypes:
        if dtypes != (np.uint8,):
            raise TypeError(f"{name} must have dtype uint8 or uint16, got {image.dtype}")
        raise TypeError(
            f"{name} must have dtype uint8 (sRGB values 0-255), got {image.dtype}; "
            "convert colours in [0, 1] with (np.clip(x, 0, 1) * 255 + 0.5).astype(np.uint8)"
        )
    return np.ascontiguousarray(image)


def _check_file_path(path, suffix: str) -> Path:
    path = Path(path)
    if path.suffix.lower() != suffix:
        raise ValueError(f"path must end in {suffix}, got {str(path)!r}")
    if path.is_dir():
        raise IsADirectoryError(f"path {str(path)!r} is a directory, expected a file name")
    parent = path.parent
    if not parent.is_dir():
        raise FileNotFoundError(f"directory {str(parent)!r} of path {str(path)!r} does not exist")
    return path


class FrameWriter(ABC):
    """Base class of the frame writers: a context manager taking frames one at a time.

    Parameters
    ----------
    path : str or os.PathLike
        Output file or directory.

    Notes
    -----
    Subclasses implement ``_write(frame)`` and ``_close()``. The base class checks every
    frame (dtype, shape, the same size as the first), counts frames, defers Ctrl-C while
    a frame is handed over, and makes :meth:`close` idempotent.
    """

    #: Channels a frame may have (RGB; the PNG writers take RGBA too).
    channels: tuple[int, ...] = (3,)
    #: Dtypes a frame may have (8 bits; the PNG writers take 16 too).
    dtypes: tuple = (np.uint8,)

    def __init__(self, path):
        self.path = Path(path)
        #: Number of frames in the output so far.
        self.frames_written = 0
        self._shape: tuple[int, ...] | None = None
        self._closed = False

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` has been called."""
        return self._closed

    @property
    def size(self) -> tuple[int, int] | None:
        """``(width, height)`` of the frames [px], or ``None`` before the first frame."""
        return None if self._shape is None else (self._shape[1], self._shape[0])

    def write(self, frame: np.ndarray) -> None:
        """Append one frame.

        Parameters
        ----------
        frame : numpy.ndarray
            ``uint8`` sRGB image, shape ``(height, width, 3)``; every frame of one writer
            must have the size of the first.

        Raises
        ------
        ValueError
            On a closed writer, or a frame of the wrong shape or size.
        TypeError
            If the frame is not a ``uint8`` NumPy array.
        """
        if self._closed:
            raise ValueError(f"write to a closed writer ({self.path})")
        frame = _check_image("frame", frame, channels=self.channels, dtypes=self.dtypes)
        if self._shape is None:
            self._shape = frame.shape
        elif frame.shape != self._shape:
            h, w = self._shape[:2]
            raise ValueError(
                f"frame {self.frames_written} has size {frame.shape[1]}x{frame.shape[0]} but "
                f"the first frame was {w}x{h}; all frames written to {self.path} must have "
                "the same size"
            )
        with DeferredInterrupt():
            self._write(frame)
            self.frames_written += 1

    def close(self) -> None:
        """Finish the output with the frames written so far; calling it again does nothing.

        Safe to call while an exception propagates (``with`` does): the output is
        complete and valid for the frames written. With no frame written, nothing is
        written and an existing file at :attr:`path` is left as it was.
        """
        if self._closed:
            return
        self._closed = True
        self._close()

    def __enter__(self):
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self._closed else "open"
        name, path = type(self).__name__, str(self.path)
        return f"{name}({path!r}, frames_written={self.frames_written}, {state})"

    @abstractmethod
    def _write(self, frame: np.ndarray) -> None:
        """Hand one checked frame to the output."""

    @abstractmethod
    def _close(self) -> None:
        """Finish the output (called once)."""


class PngWriter(FrameWriter):
    """A single PNG image: the *last* frame written, saved when the writer closes.

    Frames may be RGB or RGBA (straight alpha, as PNG has it), 8 or 16 bits a channel
    (``uint8`` or ``uint16``; 16 bits through ``pypng``, the extra ``motes[png16]``).

    Useful for "render this scene and show me the final frame". Only one frame is held
    in memory (a copy, so the caller may reuse its buffer).

    Parameters
    ----------
    path : str or os.PathLike
        Output file, ending in ``.png``.
    metadata : dict of str, optional
        Stored as PNG text chunks (see the module notes).
    """

    channels = (3, 4)
    dtypes = (np.uint8, np.uint16)

    def __init__(self, path, *, metadata: dict[str, str] | None = None):
        super().__init__(_check_file_path(path, ".png"))
        self.metadata = _check_metadata(metadata)
        self._last: np.ndarray | None = None

    def _write(self, frame: np.ndarray) -> None:
        self._last = frame.copy()

    def _close(self) -> None:
        if self._last is not None:
            _save_png(self.path, self._last, self.metadata)
            self._last = None


class SequenceWriter(FrameWriter):
    """A directory of numbered PNG files, ``frame_00000.png``, ``frame_00001.png``, ...

    Frames as :class:`PngWriter` takes them: RGB or RGBA, 8 or 16 bits.

    Each file is complete when it appears (written under a temporary name and renamed).
    The directory is created if needed. Files of an earlier, longer run with numbers
    past the last frame written are left in place (never deleted): write to an empty
    directory to get exactly this run's frames.

    Parameters
    ----------
    directory : str or os.PathLike
        Output directory.
    prefix : str
        File name before the number.
    start : int
        Number of the first frame.
    metadata : dict of str, optional
        Written with the frame count, prefix and first number to ``frames.json`` in the
        directory when the writer closes (if it wrote a frame); without metadata the
        directory holds only the frames.
    """

    channels = (3, 4)
    dtypes = (np.uint8, np.uint16)

    def __init__(
        self,
        directory,
        *,
        prefix: str = "frame_",
        start: int = 0,
        metadata: dict[str, str] | None = None,
    ):
        directory = Path(directory)
        if directory.exists() and not directory.is_dir():
            raise NotADirectoryError(f"{str(directory)!r} exists and is not a directory")
        if not isinstance(prefix, str) or os.sep in prefix or "/" in prefix:
            raise ValueError(f"prefix must be a file name prefix without '/', got {prefix!r}")
        super().__init__(directory)
        self.prefix = prefix
        self.start = check.integer("start", start, low=0)
        self.metadata = _check_metadata(metadata)
        directory.mkdir(parents=True, exist_ok=True)

    def frame_path(self, index: int) -> Path:
        """Path of the ``index``-th frame written (counted from 0)."""
        return self.path / f"{self.prefix}{self.start + index:05d}.png"

    def _write(self, frame: np.ndarray) -> None:
        _save_png(self.frame_path(self.frames_written), frame, self.metadata)

    def _close(self) -> None:
        if not self.frames_written or not self.metadata:
            return
        record = {
            **self.metadata,
            "frames": self.frames_written,
            "prefix": self.prefix,
            "start": self.start,
        }
        with replacing(self.path / SEQUENCE_METADATA) as tmp:
            Path(tmp).write_text(json.dumps(record, indent=2) + "\n")


#: The fastest a GIF plays in real time [1/s]. GIF stores delays in whole centiseconds,
#: and browsers show delays below 2 cs as 10 cs: a faster GIF gets 2 cs a frame and plays
#: slower than real time. ffmpeg rounds the cumulative time to centiseconds, so 30 fps
#: gives 3, 4, 3, 3, 4, 3, ... cs, exact on average.
GIF_MAX_FPS = 50.0


class _FfmpegWriter(FrameWriter):
    """A file encoded by ffmpeg (the binary bundled with ``imageio-ffmpeg``), raw RGB
    frames streamed to it as they are written: nothing is held back but the frame being
    handed over, whatever the frame count.

    ffmpeg is driven with :func:`subprocess.Popen` and ``imageio_ffmpeg.get_ffmpeg_exe``
    rather than ``imageio_ffmpeg.write_frames``: that generator kills ffmpeg when a
    ``KeyboardInterrupt`` reaches it mid-frame, which would leave a file without its end,
    and it starts ffmpeg through ``preexec_fn``, which is unsafe in a process with threads
    (Numba's). Here ffmpeg starts in a new session (``start_new_session``) and a frame is
    never interrupted halfway (see the module notes). Subclasses give the command.
    """

    def __init__(self, path: Path, *, fps: float, metadata):
        super().__init__(path)
        self.metadata = _check_metadata(metadata)
        self.fps = check.positive("fps", fps)
        self._process: subprocess.Popen | None = None
        self._tmp: Path | None = None
        self._log = None
        self._failure: str | None = None

    @abstractmethod
    def _command(self, width: int, height: int, output: Path) -> list[str]:
        """ffmpeg's command line for frames of ``width`` x ``height`` into ``output``."""

    def _input(self, width: int, height: int, fps: float | None = None) -> list[str]:
        """ffmpeg's arguments up to its input: raw RGB frames on stdin at ``fps``
        (default: the writer's)."""
        import imageio_ffmpeg

        rate = Fraction(self.fps if fps is None else fps).limit_denominator(100_000)
        return [
            imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-nostats", "-loglevel", "error",
            "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{width}x{height}",
            "-framerate", str(rate), "-i", "pipe:0", "-an",
        ]  # fmt: skip

    def _start(self, width: int, height: int) -> None:
        self._tmp = temporary_sibling(self.path)
        # ffmpeg's messages, read back if it fails; closed by _cleanup()
        self._log = tempfile.TemporaryFile()  # noqa: SIM115
        # Own session (POSIX) or process group (Windows): the terminal's Ctrl-C goes to
        # the foreground process group and must not stop ffmpeg before close() finishes
        # the file.
        if os.name == "nt":  # pragma: no cover
            isolate = {"creationflags": subprocess.CREATE_NEW_PROCESS_GROUP}
        else:
            isolate = {"start_new_session": True}
        try:
            self._process = subprocess.Popen(
                self._command(width, height, self._tmp),
                stdin=subprocess.PIPE,
                stdout=subprocess.DEVNULL,
                stderr=self._log,
                bufsize=0,
                **isolate,
            )
        except BaseException:
            self._cleanup()
            raise

    def _write(self, frame: np.ndarray) -> None:
        if self._failure is not None:
            raise RuntimeError(self._failure)
        if self._process is None:
            self._start(frame.shape[1], frame.shape[0])
        data = memoryview(frame).cast("B")
        fd = self._process.stdin.fileno()
        try:
            while data:
                data = data[os.write(fd, data) :]
        except BrokenPipeError:
            with contextlib.suppress(BrokenPipeError):
                self._process.stdin.close()
            self._process.wait()
            self._failure = f"ffmpeg stopped while writing {self.path}: {self._ffmpeg_message()}"
            self._process = None
            self._cleanup()
            raise RuntimeError(self._failure) from None

    def _ffmpeg_message(self) -> str:
        if self._log is None:
            return ""
        self._log.seek(0)
        text = self._log.read().decode(errors="replace").strip()
        return text[-2000:] or f"exit status {self._process.returncode}"

    def _cleanup(self) -> None:
        if self._tmp is not None:
            discard(self._tmp)
            self._tmp = None
        if self._log is not None:
            self._log.close()
            self._log = None

    def _close(self) -> None:
        process = self._process
        if process is None:
            self._cleanup()
            return
        try:
            with contextlib.suppress(BrokenPipeError):
                process.stdin.close()
            returncode = process.wait()
        except BaseException:
            # Interrupted again while ffmpeg finishes: give up on this file.
            process.kill()
            process.wait()
            self._cleanup()
            raise
        if returncode != 0:
            message = self._ffmpeg_message()
            self._cleanup()
            raise RuntimeError(f"ffmpeg failed to write {self.path}: {message}")
        try:
            self._finish_file(self._tmp)
            os.replace(self._tmp, self.path)
            self._tmp = None
        finally:
            self._cleanup()

    def _finish_file(self, tmp: Path) -> None:
        """Complete the file ffmpeg wrote at ``tmp`` before it is moved into place."""
        return None


class GifWriter(_FfmpegWriter):
    """An animated GIF that loops forever, frames streamed to ffmpeg as they are written.

    Each frame gets its own adaptive palette of up to 256 colours (ffmpeg's
    ``palettegen`` with ``stats_mode=single``, applied by ``paletteuse`` with
    Floyd-Steinberg dithering): memory stays flat whatever the frame count. ffmpeg stores
    only the part of a frame that changed, so a still scene stays small. The metadata goes
    into a GIF comment extension, added before the first frame when ffmpeg has finished.

    Parameters
    ----------
    path : str or os.PathLike
        Output file, ending in ``.gif``.
    fps : float
        Frames per second (> 0). GIF delays are whole centiseconds; at most
        :data:`GIF_MAX_FPS` (50) play in real time.
    metadata : dict of str, optional
        Stored as a JSON object in the GIF comment.
    """

    def __init__(self, path, *, fps: float = 30.0, metadata: dict[str, str] | None = None):
        super().__init__(_check_file_path(path, ".gif"), fps=fps, metadata=metadata)

    def _command(self, width: int, height: int, output: Path) -> list[str]:
        palette = (
            "split[frames][again];[again]palettegen=stats_mode=single[palette];"
            "[frames][palette]paletteuse=new=1:dither=floyd_steinberg"
        )
        fps = min(self.fps, GIF_MAX_FPS)
        return [*self._input(width, height, fps), "-vf", palette, "-loop", "0", "-f", "gif", "-y",
                str(output)]  # fmt: skip

    def _finish_file(self, tmp: Path) -> None:
        if self.metadata:
            _add_gif_comment(tmp, json.dumps(self.metadata))


def _add_gif_comment(path: Path, text: str) -> None:
    """Insert a comment extension holding ``text`` (UTF-8) into the GIF at ``path``.

    GIF89a (section 24) places extensions between the logical screen (the 13-byte header
    and screen descriptor, then the global colour table if its flag is set) and the
    first image; a comment is ``0x21 0xFE``, data sub-blocks of at most 255 bytes each
    preceded by its length, and a zero-length terminator. The file is copied once, in
    blocks, under a temporary name.
    """
    data = text.encode()
    blocks = b"".join(
        bytes([len(data[k : k + 255])]) + data[k : k + 255] for k in range(0, len(data), 255)
    )
    comment = b"\x21\xfe" + blocks + b"\x00"
    with open(path, "rb") as source:
        head = source.read(13)
        if len(head) < 13 or head[:6] != b"GIF89a":
            raise RuntimeError(f"ffmpeg did not write a GIF89a file at {path}")
        packed = head[10]
        table = 3 * 2 ** ((packed & 0x07) + 1) if packed & 0x80 else 0
        head += source.read(table)
        with replacing(path) as tmp, open(tmp, "wb") as target:
            target.write(head + comment)
            shutil.copyfileobj(source, target, 1 << 20)


class Mp4Writer(_FfmpegWriter):
    """An H.264 MP4 video, frames streamed to ffmpeg as they are written.

    ffmpeg (the binary bundled with ``imageio-ffmpeg``) encodes with libx264 into
    ``yuv420p`` with BT.709 colour, tagged as such, so browsers and players show the
    colours as written. The file is written under a temporary name; :meth:`close` ends the
    stream, waits for ffmpeg to finish the file and moves it into place.

    Odd sizes: yuv420p needs an even width and height, so a frame with an odd dimension
    is padded by one black column on the right and/or one black row at the bottom.

    Parameters
    ----------
    path : str or os.PathLike
        Output file, ending in ``.mp4``.
    fps : float
        Frames per second (> 0).
    crf : int
        x264 constant rate factor, 0 (lossless) to 51 (worst); 18 is visually lossless
        for most material, each +6 about halves the size.
    preset : str
        x264 speed/size trade-off, ``"ultrafast"`` ... ``"veryslow"``.
    metadata : dict of str, optional
        Stored as a JSON object in the MP4 ``comment`` tag.

    Notes
    -----
    The encoder is driven as :class:`_FfmpegWriter` says: in a session of its own, a
    frame never interrupted halfway.
    """

    PRESETS = (
        "ultrafast",
        "superfast",
        "veryfast",
        "faster",
        "fast",
        "medium",
        "slow",
        "slower",
        "veryslow",
    )

    def __init__(
        self,
        path,
        *,
        fps: float = 30.0,
        crf: int = 18,
        preset: str = "medium",
        metadata: dict[str, str] | None = None,
    ):
        super().__init__(_check_file_path(path, ".mp4"), fps=fps, metadata=metadata)
        self.crf = check.integer("crf", crf, low=0)
        if self.crf > 51:
            raise ValueError(f"crf must be <= 51, got {self.crf}")
        self.preset = check.choice("preset", preset, self.PRESETS)

    def _command(self, width: int, height: int, output: Path) -> list[str]:
        filters = [
            # pad to even dimensions (a no-op when they already are)
            "pad=ceil(iw/2)*2:ceil(ih/2)*2",
            "scale=out_color_matrix=bt709:out_range=tv",
            "format=yuv420p",
            "setparams=color_primaries=bt709:color_trc=iec61966-2-1:colorspace=bt709:range=tv",
        ]
        return [
            *self._input(width, height),
            "-vf",
            ",".join(filters),
            "-c:v",
            "libx264",
            "-preset",
            self.preset,
            "-crf",
            str(self.crf),
            # index at the front, so browsers can play before the whole file has loaded
            *(["-metadata", f"comment={json.dumps(self.metadata)}"] if self.metadata else []),
            "-movflags",
            "+faststart",
            "-f",
            "mp4",
            "-y",
            str(output),
        ]


def open_writer(
    path, *, fps: float = 30.0, crf: int = 18, metadata: dict[str, str] | None = None
) -> FrameWriter:
    """Open a frame writer chosen by the form of ``path``.

    Parameters
    ----------
    path : str or os.PathLike
        ``*.mp4`` (H.264 video), ``*.gif`` (looping animation), ``*.png`` (one still:
        the last frame written), or a directory (numbered PNG files): a path ending in
        ``/``, an existing directory, or a name without suffix.
    fps : float
        Frames per second of a video or GIF (> 0); ignored by PNG output.
    crf : int
        H.264 quality for ``.mp4`` (0-51, lower is better); ignored otherwise.
    metadata : dict of str, optional
        Recorded in the output (see the module notes); read back with
        :func:`read_metadata`.

    Returns
    -------
    FrameWriter
        Use it as a context manager, so the output is finished even if the run stops
        with an exception or Ctrl-C.

    Raises
    ------
    ValueError
        For any other suffix.

    Examples
    --------
    >>> with open_writer("out/frames/") as out:  # doctest: +SKIP
    ...     out.write(image)
    """
    text = os.fspath(path)
    if not isinstance(text, str):
        raise TypeError(f"path must be a str or os.PathLike, got {path!r}")
    target = Path(text)
    if text.endswith(("/", os.sep)) or target.is_dir() or target.suffix == "":
        return SequenceWriter(target, metadata=metadata)
    suffix = target.suffix.lower()
    if suffix == ".mp4":
        return Mp4Writer(target, fps=fps, crf=crf, metadata=metadata)
    if suffix == ".gif":
        return GifWriter(target, fps=fps, metadata=metadata)
    if suffix == ".png":
        check.positive("fps", fps)
        return PngWriter(target, metadata=metadata)
    raise ValueError(
        f"cannot write frames to {text!r}: the suffix must be one of {', '.join(SUFFIXES)}, "
        "or the path a directory (end it with '/') for numbered PNG files"
    )


def contact_sheet(
    frames: Iterable[np.ndarray],
    *,
    columns: int = 4,
    gap: int = 4,
    background: Sequence[int] = (0, 0, 0),
    scale: int = 1,
) -> np.ndarray:
    """Tile frames into one image, left to right and top to bottom.

    Parameters
    ----------
    frames : iterable of numpy.ndarray
        At least one ``uint8`` image of shape ``(height, width, 3)``, all the same size.
    columns : int
        Tiles per row (>= 1); fewer if there are fewer frames.
    gap : int
        Pixels between tiles and around the border (>= 0).
    background : sequence of 3 int
        sRGB colour of the gaps and of empty cells in the last row, 0-255.
    scale : int
        Integer downscaling factor (>= 1): each tile is the mean of ``scale x scale``
        pixel blocks (rounded), after cropping the frame to a multiple of ``scale``.

    Returns
    -------
    numpy.ndarray
        ``uint8`` image of shape ``(rows*h + (rows+1)*gap, cols*w + (cols+1)*gap, 3)``
        where ``h, w`` are the tile size after scaling.

    Examples
    --------
    >>> import numpy as np
    >>> frames = [np.full((48, 64, 3), v, dtype=np.uint8) for v in (0, 100, 200)]
    >>> contact_sheet(frames, columns=2, gap=2, scale=2).shape
    (54, 70, 3)
    """
    images = [_check_image(f"frames[{i}]", f) for i, f in enumerate(frames)]
    if not images:
        raise ValueError("frames must hold at least one image")
    for i, image in enumerate(images[1:], 1):
        if image.shape != images[0].shape:
            raise ValueError(
                f"frames[{i}] has shape {image.shape}, frames[0] has {images[0].shape}; "
                "all frames of a contact sheet must have the same size"
            )
    columns = check.integer("columns", columns, low=1)
    gap = check.integer("gap", gap, low=0)
    scale = check.integer("scale", scale, low=1)
    colour = np.asarray(background)
    if colour.shape != (3,) or not np.issubdtype(colour.dtype, np.integer):
        raise ValueError(f"background must be 3 integers (sRGB 0-255), got {background!r}")
    if colour.min() < 0 or colour.max() > 255:
        raise ValueError(f"background values must be in 0-255, got {background!r}")

    stack = np.stack(images)
    n, h, w, _ = stack.shape
    if scale > 1:
        th, tw = h // scale, w // scale
        if th == 0 or tw == 0:
            raise ValueError(f"scale {scale} is larger than the frame size {w}x{h}")
        blocks = stack[:, : th * scale, : tw * scale].reshape(n, th, scale, tw, scale, 3)
        # integer mean rounded half up: exact, and no float round-trip
        total = blocks.sum(axis=(2, 4), dtype=np.uint32)
        stack = ((total + scale * scale // 2) // (scale * scale)).astype(np.uint8)
        h, w = th, tw

    cols = min(columns, n)
    rows = math.ceil(n / cols)
    sheet = np.empty((rows * h + (rows + 1) * gap, cols * w + (cols + 1) * gap, 3), np.uint8)
    sheet[...] = colour.astype(np.uint8)
    for k in range(n):
        r, c = divmod(k, cols)
        y, x = gap + r * (h + gap), gap + c * (w + gap)
        sheet[y : y + h, x : x + w] = stack[k]
    return sheet


def save_image(path, image: np.ndarray) -> None:
    """Save an image as PNG, atomically: the file appears complete or not at all.

    Parameters
    ----------
    path : str or os.PathLike
        Output file, ending in ``.png``. An existing file is replaced only once the new
        one is complete.
    image : numpy.ndarray
        ``uint8`` sRGB image, shape ``(height, width, 3)``, or ``(height, width, 4)`` with
        straight (not premultiplied) alpha.
    """
    path = _check_file_path(path, ".png")
    _save_png(path, _check_image("image", image, channels=(3, 4)))


def _save_png(path: Path, image: np.ndarray, metadata: dict[str, str] | None = None) -> None:
    if image.dtype == np.uint16:
        _save_png16(path, image, metadata)
        return
    from PIL import Image, PngImagePlugin

    info = None
    if metadata:
        info = PngImagePlugin.PngInfo()
        for key, value in metadata.items():
            # iTXt (UTF-8) where tEXt's Latin-1 cannot hold the value (a path, a name)
            if value.isascii():
                info.add_text(key, value)
            else:
                info.add_itxt(key, value)
    with replacing(path) as tmp:
        # the mode follows from the shape: (h, w, 3) is RGB, (h, w, 4) RGBA
        Image.fromarray(image).save(tmp, format="PNG", pnginfo=info)


def _save_png16(path: Path, image: np.ndarray, metadata: dict[str, str] | None) -> None:
    """A 16-bit RGB or RGBA PNG, through pypng (Pillow holds 16 bits in one channel
    only); the metadata as the same text chunks Pillow writes (``tEXt``, or ``iTXt`` for
    text beyond Latin-1: keyword, no compression, no language)."""
    png = _pypng()
    height, width, channels = image.shape
    writer = png.Writer(width, height, greyscale=False, alpha=channels == 4, bitdepth=16)
    encoded = io.BytesIO()
    writer.write(encoded, image.reshape(height, -1))
    chunks = list(png.Reader(bytes=encoded.getvalue()).chunks())
    for key, value in (metadata or {}).items():
        if value.isascii():
            chunk = (b"tEXt", key.encode("latin-1") + b"\0" + value.encode("latin-1"))
        else:
            chunk = (b"iTXt", key.encode("latin-1") + b"\0\0\0\0\0" + value.encode())
        chunks.insert(1, chunk)  # after IHDR
    with replacing(path) as tmp, open(tmp, "wb") as out:
        png.write_chunks(out, chunks)


def _pypng():
    try:
        import png
    except ImportError:
        raise ImportError(
            "16-bit PNG needs the pypng package: pip install 'motes[png16]'"
        ) from None
    return png


def read_png16(path) -> np.ndarray:
    """A 16-bit PNG as a (height, width, 3 or 4) ``uint16`` array (through pypng)."""
    png = _pypng()
    with open(path, "rb") as stream:
        width, height, rows, info = png.Reader(file=stream).asDirect()
        image = np.vstack([np.asarray(row, dtype=np.uint16) for row in rows])
    return image.reshape(height, width, info["planes"])


def read_metadata(path) -> dict:
    """The metadata a writer recorded in ``path`` (see the module notes).

    ``path`` is a PNG, GIF or MP4 file, or a PNG sequence directory (its ``frames.json``,
    which adds ``frames``, ``prefix`` and ``start``). Returns ``{}`` when there is none.
    """
    path = Path(path)
    if path.is_dir():
        side = path / SEQUENCE_METADATA
        return json.loads(side.read_text()) if side.is_file() else {}
    suffix = path.suffix.lower()
    if suffix in (".png", ".gif"):
        from PIL import Image

        with Image.open(path) as image:
            if suffix == ".png":
                return dict(image.text)
            comment = image.info.get("comment", b"")
        return json.loads(comment) if comment else {}
    if suffix == ".mp4":
        return _mp4_comment(path)
    raise ValueError(f"cannot read metadata of {str(path)!r}: not a .png, .gif, .mp4 or folder")


def _mp4_comment(path: Path) -> dict:
    """The JSON ``comment`` tag, read with ffmpeg's metadata muxer (``ffmetadata``
    escapes ``=``, ``;``, ``#``, ``\\`` and newlines with a backslash)."""
    import imageio_ffmpeg

    if not path.is_file():
        raise FileNotFoundError(f"no such file: {str(path)!r}")
    result = subprocess.run(
        [imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-i", str(path), "-f", "ffmetadata", "-"],
        capture_output=True,
        check=True,
    )
    text = result.stdout.decode("utf-8")
    # Join continued lines (an escaped newline), then split on unescaped newlines.
    lines, current, escaped = [], [], False
    for char in text:
        if escaped:
            current.append(char)
            escaped = False
        elif char == "\\":
            escaped = True
        elif char == "\n":
            lines.append("".join(current))
            current = []
        else:
            current.append(char)
    lines.append("".join(current))
    for line in lines:
        if line.startswith("comment="):
            return json.loads(line[len("comment=") :])
    return {}


def read_image(path, *, alpha: bool = False) -> np.ndarray:
    """Read an image file (any format Pillow reads) as sRGB.

    Parameters
    ----------
    path : str or os.PathLike
        Image file.
    alpha : bool
        Keep (or add, opaque) an alpha channel.

    Returns
    -------
    numpy.ndarray
        ``uint8`` array of shape ``(height, width, 3)`` (``4`` with ``alpha``); palette
        and grey images are expanded to RGB. A 16-bit PNG is read at 8 bits
        (:func:`read_png16` reads its 16).
    """
    from PIL import Image

    with Image.open(path) as image:
        return np.array(image.convert("RGBA" if alpha else "RGB"))
