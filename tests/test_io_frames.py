"""Frame writers (PNG, sequence, GIF, MP4), contact sheets, and safe interruption."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pytest
from PIL import Image

import interrupt_writer
from motes.io import _atomic
from motes.io.frames import (
    GifWriter,
    Mp4Writer,
    PngWriter,
    SequenceWriter,
    contact_sheet,
    open_writer,
    read_image,
    save_image,
)

HEIGHT, WIDTH = 48, 64
HELPER = Path(interrupt_writer.__file__)
RAW_RGB = ["-f", "rawvideo", "-pix_fmt", "rgb24", "-"]


def make_frame(k: int, height: int = HEIGHT, width: int = WIDTH) -> np.ndarray:
    """A smooth gradient, different for each k: lossy codecs reproduce it closely."""
    yy, xx = np.mgrid[0:height, 0:width]
    red = 40 + 2 * xx + 3 * k
    green = 30 + 3 * yy
    blue = np.full_like(xx, 90 + 7 * k)
    return np.stack([red, green, blue], axis=-1).astype(np.uint8)


def leftovers(directory: Path) -> list[str]:
    """Temporary files a writer left behind."""
    return sorted(p.name for p in directory.iterdir() if ".part" in p.name)


def decode_mp4(path: Path, width: int, height: int) -> tuple[str, list[np.ndarray]]:
    """The stream description line and the frames of a video, decoded by ffmpeg.

    ``imageio_ffmpeg.read_frames`` would do, but it leaves its pipes open when ffmpeg has
    already exited, which strict pytest reports as a ResourceWarning.
    """
    result = subprocess.run(
        [imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-i", str(path), *RAW_RGB],
        capture_output=True,
        check=True,
    )
    stream = next(line.strip() for line in result.stderr.decode().splitlines() if "Video:" in line)
    data = np.frombuffer(result.stdout, np.uint8)
    assert data.size % (width * height * 3) == 0, "decoded size differs from the expected"
    return stream, list(data.reshape(-1, height, width, 3))


@pytest.fixture
def default_sigint():
    """Python's own Ctrl-C handler for the duration of a test."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


# -- each writer writes a file that decodes ---------------------------------------------


def test_png_keeps_the_last_frame_exactly(tmp_path):
    path = tmp_path / "still.png"
    with open_writer(path) as out:
        assert isinstance(out, PngWriter)
        for k in range(3):
            out.write(make_frame(k))
    assert out.frames_written == 3
    with Image.open(path) as image:
        assert image.format == "PNG"
        np.testing.assert_array_equal(np.asarray(image), make_frame(2))
    assert leftovers(tmp_path) == []


def test_sequence_writes_numbered_files_in_order(tmp_path):
    directory = tmp_path / "frames"
    with open_writer(f"{directory}/") as out:
        assert isinstance(out, SequenceWriter)
        for k in range(4):
            out.write(make_frame(k))
    names = sorted(os.listdir(directory))
    assert names == [f"frame_{k:05d}.png" for k in range(4)]
    for k, name in enumerate(names):
        np.testing.assert_array_equal(read_image(directory / name), make_frame(k))


@pytest.mark.parametrize("form", ["existing", "no_suffix"])
def test_directory_forms_give_a_sequence(tmp_path, form):
    target = tmp_path / "out.d" if form == "existing" else tmp_path / "out"
    if form == "existing":
        target.mkdir()
    with open_writer(target) as out:
        assert isinstance(out, SequenceWriter)
        out.write(make_frame(0))
    assert os.listdir(target) == ["frame_00000.png"]


def test_gif_has_every_frame_loops_and_keeps_time(tmp_path):
    path = tmp_path / "loop.gif"
    fps = 30.0
    with open_writer(path, fps=fps) as out:
        assert isinstance(out, GifWriter)
        for k in range(6):
            out.write(make_frame(k))
    with Image.open(path) as image:
        assert image.format == "GIF"
        assert image.size == (WIDTH, HEIGHT)
        assert image.n_frames == 6
        assert image.info["loop"] == 0
        durations = []
        for k in range(6):
            image.seek(k)
            durations.append(image.info["duration"])
            decoded = np.asarray(image.convert("RGB"), dtype=np.int16)
            # A 256-colour adaptive palette of a gradient with fewer than 256 distinct
            # colours per channel, dithered: errors of a few levels, mean well below 3.
            assert np.abs(decoded - make_frame(k)).mean() < 3
    # delays are whole centiseconds, rounded on the cumulative time: 6 frames = 20 cs
    assert sum(durations) == 200
    assert set(durations) <= {30, 40}


def test_mp4_has_every_frame_and_decodes_close_to_input(tmp_path):
    path = tmp_path / "movie.mp4"
    with open_writer(path, fps=24) as out:
        assert isinstance(out, Mp4Writer)
        for k in range(8):
            out.write(make_frame(k))
    frames, seconds = imageio_ffmpeg.count_frames_and_secs(str(path))
    assert frames == 8
    assert seconds == pytest.approx(8 / 24, abs=0.05)
    stream, decoded = decode_mp4(path, WIDTH, HEIGHT)
    assert "h264" in stream and "yuv420p" in stream and f"{WIDTH}x{HEIGHT}" in stream
    assert "bt709" in stream  # tagged, so players convert back with the same matrix
    assert len(decoded) == 8
    # yuv420p halves the chroma resolution and limited range quantises to 219 levels; at
    # crf 18 a smooth gradient comes back within a few levels on average.
    error = np.abs(decoded[0].astype(np.int16) - make_frame(0))
    assert error.mean() < 2.5
    assert leftovers(tmp_path) == []


def test_mp4_pads_odd_sizes_to_even(tmp_path):
    path = tmp_path / "odd.mp4"
    frame = make_frame(0, height=HEIGHT - 1, width=WIDTH - 1)
    with Mp4Writer(path) as out:
        out.write(frame)
        out.write(frame)
    stream, decoded = decode_mp4(path, WIDTH, HEIGHT)
    assert f"{WIDTH}x{HEIGHT}" in stream
    assert len(decoded) == 2
    inner = decoded[0][: HEIGHT - 1, : WIDTH - 1].astype(np.int16)
    assert np.abs(inner - frame).mean() < 3  # same codec tolerance as above, plus the edge


# -- interruption ------------------------------------------------------------------------


class Stop(Exception):
    pass


@pytest.mark.parametrize("name", ["movie.mp4", "loop.gif", "still.png", "frames/"])
def test_exception_after_k_frames_leaves_valid_output(tmp_path, name):
    path = tmp_path / name
    with pytest.raises(Stop), open_writer(path) as out:
        for k in range(3):
            out.write(make_frame(k))
        raise Stop
    assert out.closed and out.frames_written == 3
    if name.endswith(".mp4"):
        assert imageio_ffmpeg.count_frames_and_secs(str(path))[0] == 3
    elif name.endswith(".gif"):
        with Image.open(path) as image:
            assert image.n_frames == 3
    elif name.endswith(".png"):
        np.testing.assert_array_equal(read_image(path), make_frame(2))
    else:
        assert sorted(os.listdir(path)) == [f"frame_{k:05d}.png" for k in range(3)]
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("name", ["movie.mp4", "loop.gif", "still.png"])
def test_run_without_frames_keeps_an_earlier_file(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(b"earlier output")
    with pytest.raises(Stop), open_writer(path):
        raise Stop
    assert path.read_bytes() == b"earlier output"
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("name", ["movie.mp4", "loop.gif", "still.png"])
def test_interrupted_run_replaces_an_earlier_file_only_when_complete(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(b"earlier output")
    with pytest.raises(Stop), open_writer(path) as out:
        out.write(make_frame(0))
        out.write(make_frame(1))
        # the earlier file stays in place until the new one is complete
        assert path.read_bytes() == b"earlier output"
        raise Stop
    assert path.read_bytes() != b"earlier output"
    if name.endswith(".png"):
        np.testing.assert_array_equal(read_image(path), make_frame(1))
    elif name.endswith(".gif"):
        with Image.open(path) as image:
            assert image.n_frames == 2
    else:
        assert imageio_ffmpeg.count_frames_and_secs(str(path))[0] == 2


def run_helper(output: Path, limit: int, wait_for: str) -> subprocess.CompletedProcess:
    """Start the helper in its own process group, Ctrl-C the group after ``wait_for``."""
    process = subprocess.Popen(
        [sys.executable, str(HELPER), str(output), str(limit)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    lines = []
    try:
        for line in process.stdout:
            lines.append(line.strip())
            if lines[-1] == wait_for:
                break
        # as the terminal does on Ctrl-C: the whole (foreground) process group
        os.killpg(process.pid, signal.SIGINT)
        out, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:  # pragma: no cover - only if the test fails
            process.kill()
            process.communicate()
    lines += out.splitlines()
    return subprocess.CompletedProcess(process.args, process.returncode, "\n".join(lines), err)


@pytest.mark.skipif(not hasattr(os, "killpg"), reason="needs POSIX process groups")
def test_ctrl_c_leaves_a_playable_mp4_with_every_frame_written(tmp_path):
    path = tmp_path / "movie.mp4"
    result = run_helper(path, limit=100_000, wait_for="frame 5")
    assert result.returncode == 130, result.stderr
    last = result.stdout.splitlines()[-1]
    assert last.startswith("interrupted ")
    written = int(last.split()[1])
    assert written >= 5
    # every frame the writer counted is in the file, and the file has its index
    assert imageio_ffmpeg.count_frames_and_secs(str(path))[0] == written
    width, height = interrupt_writer.WIDTH, interrupt_writer.HEIGHT
    stream, decoded = decode_mp4(path, width, height)
    assert f"{width}x{height}" in stream and len(decoded) == written
    assert leftovers(tmp_path) == []


@pytest.mark.skipif(not hasattr(os, "killpg"), reason="needs POSIX process groups")
def test_ctrl_c_before_the_first_frame_keeps_an_earlier_file(tmp_path):
    path = tmp_path / "movie.mp4"
    path.write_bytes(b"earlier output")
    result = run_helper(path, limit=0, wait_for="ready")
    assert result.returncode == 130, result.stderr
    assert result.stdout.splitlines()[-1] == "interrupted 0"
    assert path.read_bytes() == b"earlier output"
    assert leftovers(tmp_path) == []


def test_deferred_interrupt_lets_the_block_finish(default_sigint):
    steps = []
    with pytest.raises(KeyboardInterrupt), _atomic.DeferredInterrupt():
        os.kill(os.getpid(), signal.SIGINT)
        steps.append("after the signal")
    assert steps == ["after the signal"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_second_interrupt_is_obeyed_at_once(default_sigint):
    steps = []
    with pytest.raises(KeyboardInterrupt), _atomic.DeferredInterrupt():
        os.kill(os.getpid(), signal.SIGINT)
        steps.append("first")
        os.kill(os.getpid(), signal.SIGINT)
        steps.append("second")  # pragma: no cover - must not run
    assert steps == ["first"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_ctrl_c_during_write_keeps_the_frame_whole(tmp_path, default_sigint, monkeypatch):
    """A SIGINT raised while a frame is being written lands after it, counted."""
    path = tmp_path / "still.png"
    writer = PngWriter(path)
    original = PngWriter._write

    def interrupted_write(self, frame):
        os.kill(os.getpid(), signal.SIGINT)
        original(self, frame)

    monkeypatch.setattr(PngWriter, "_write", interrupted_write)
    with pytest.raises(KeyboardInterrupt), writer:
        writer.write(make_frame(0))
    assert writer.frames_written == 1
    np.testing.assert_array_equal(read_image(path), make_frame(0))


# -- checks and errors -------------------------------------------------------------------


def test_unknown_suffix_lists_the_allowed_ones(tmp_path):
    with pytest.raises(ValueError, match=r"\.mp4, \.gif, \.png.*directory"):
        open_writer(tmp_path / "movie.avi")


@pytest.mark.parametrize(
    ("frame", "error", "match"),
    [
        (np.zeros((HEIGHT, WIDTH, 3), np.float32), TypeError, "dtype uint8"),
        (np.zeros((HEIGHT, WIDTH, 4), np.uint8), ValueError, r"shape \(height, width, 3\)"),
        (np.zeros((HEIGHT, WIDTH), np.uint8), ValueError, "shape"),
        (np.zeros((0, WIDTH, 3), np.uint8), ValueError, "shape"),
        ([[[0, 0, 0]]], TypeError, "NumPy array"),
    ],
)
def test_bad_frames_are_refused(tmp_path, frame, error, match):
    with open_writer(tmp_path / "movie.mp4") as out, pytest.raises(error, match=match):
        out.write(frame)
    assert out.frames_written == 0


def test_png_writers_take_rgba_and_16_bits_but_not_floats(tmp_path):
    with open_writer(tmp_path / "still.png") as out:
        with pytest.raises(TypeError, match="dtype uint8 or uint16"):
            out.write(np.zeros((HEIGHT, WIDTH, 3), np.float32))
        with pytest.raises(ValueError, match=r"shape \(height, width, 3 or 4\)"):
            out.write(np.zeros((HEIGHT, WIDTH, 2), np.uint8))
        out.write(np.full((HEIGHT, WIDTH, 4), 200, np.uint8))
    assert read_image(tmp_path / "still.png", alpha=True)[0, 0].tolist() == [200] * 4


def test_frames_of_one_writer_must_have_one_size(tmp_path):
    with open_writer(tmp_path / "movie.mp4") as out:
        out.write(make_frame(0))
        message = "frame 1 has size 32x48 but the first frame was 64x48"
        with pytest.raises(ValueError, match=message):
            out.write(make_frame(1)[:, :32])
    assert imageio_ffmpeg.count_frames_and_secs(str(tmp_path / "movie.mp4"))[0] == 1


def test_write_after_close_is_refused(tmp_path):
    out = open_writer(tmp_path / "loop.gif")
    out.write(make_frame(0))
    out.close()
    out.close()  # idempotent
    with pytest.raises(ValueError, match="closed"):
        out.write(make_frame(1))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"fps": 0}, "fps must be > 0"), ({"crf": 52}, "crf must be <= 51")],
)
def test_bad_options(tmp_path, kwargs, match):
    with pytest.raises(ValueError, match=match):
        open_writer(tmp_path / "movie.mp4", **kwargs)


def test_ffmpeg_failure_is_reported_and_keeps_an_earlier_file(tmp_path, monkeypatch):
    path = tmp_path / "movie.mp4"
    path.write_bytes(b"earlier output")
    command = Mp4Writer._command

    def broken_command(self, width, height, output):
        args = command(self, width, height, output)
        args[args.index("libx264")] = "no-such-encoder"
        return args

    monkeypatch.setattr(Mp4Writer, "_command", broken_command)
    # ffmpeg exits at once: the error surfaces from write() (broken pipe) or close()
    with pytest.raises(RuntimeError, match=r"ffmpeg .*no-such-encoder"), Mp4Writer(path) as out:
        for k in range(50):
            out.write(make_frame(k))
    assert path.read_bytes() == b"earlier output"
    assert leftovers(tmp_path) == []


def test_missing_directory_is_reported_at_open(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        open_writer(tmp_path / "nowhere" / "movie.mp4")


@pytest.mark.parametrize(
    ("fps", "delays"),
    [(10.0, [100] * 4), (30.0, [30, 40, 30, 30]), (100.0, [20] * 4)],  # 2 cs at most
)
def test_slow_and_fast_gif_delays(tmp_path, fps, delays):
    path = tmp_path / "t.gif"
    with open_writer(path, fps=fps) as out:
        for k in range(4):
            out.write(make_frame(k))
    with Image.open(path) as image:
        got = []
        for k in range(image.n_frames):
            image.seek(k)
            got.append(image.info["duration"])
    assert got == delays


# -- contact sheets, stills --------------------------------------------------------------


def test_contact_sheet_places_tiles_and_gaps():
    frames = [np.full((4, 6, 3), 10 * (k + 1), np.uint8) for k in range(5)]
    sheet = contact_sheet(frames, columns=3, gap=2, background=(1, 2, 3))
    assert sheet.shape == (2 * 4 + 3 * 2, 3 * 6 + 4 * 2, 3)
    for k in range(5):
        r, c = divmod(k, 3)
        y, x = 2 + r * 6, 2 + c * 8
        assert np.all(sheet[y : y + 4, x : x + 6] == 10 * (k + 1))
    # the gap and the empty sixth cell hold the background
    np.testing.assert_array_equal(sheet[0, 0], [1, 2, 3])
    np.testing.assert_array_equal(sheet[8:12, 18:24], np.broadcast_to([1, 2, 3], (4, 6, 3)))


def test_contact_sheet_downscales_by_block_means():
    frame = np.zeros((4, 4, 3), np.uint8)
    frame[::2, ::2] = 255  # one bright pixel per 2x2 block: mean 63.75
    frame[1, 1] = 255  # the top-left block has two: mean 127.5, rounds half up
    sheet = contact_sheet([frame], gap=0, scale=2)
    assert sheet.shape == (2, 2, 3)
    np.testing.assert_array_equal(sheet[..., 0], [[128, 64], [64, 64]])


def test_contact_sheet_uses_fewer_columns_for_few_frames():
    sheet = contact_sheet([make_frame(0)] * 2, columns=4, gap=0)
    assert sheet.shape == (HEIGHT, 2 * WIDTH, 3)


@pytest.mark.parametrize(
    ("frames", "kwargs", "match"),
    [
        ([], {}, "at least one"),
        ([make_frame(0), make_frame(0)[:10]], {}, "same size"),
        ([make_frame(0)], {"columns": 0}, "columns must be >= 1"),
        ([make_frame(0)], {"background": (0, 0, 300)}, "0-255"),
        ([make_frame(0)], {"scale": 100}, "larger than the frame"),
    ],
)
def test_contact_sheet_errors(frames, kwargs, match):
    with pytest.raises(ValueError, match=match):
        contact_sheet(frames, **kwargs)


def test_save_and_read_image_round_trip(tmp_path):
    rgba = np.dstack([make_frame(3), np.full((HEIGHT, WIDTH), 200, np.uint8)])
    save_image(tmp_path / "rgba.png", rgba)
    save_image(tmp_path / "rgb.png", make_frame(3))
    np.testing.assert_array_equal(read_image(tmp_path / "rgb.png"), make_frame(3))
    assert read_image(tmp_path / "rgba.png").shape == (HEIGHT, WIDTH, 3)
    with pytest.raises(ValueError, match=r"must end in \.png"):
        save_image(tmp_path / "x.jpg", make_frame(0))


def test_save_image_failure_keeps_the_earlier_file(tmp_path, monkeypatch):
    path = tmp_path / "still.png"
    save_image(path, make_frame(0))
    before = path.read_bytes()

    def failing_save(self, fp, *args, **kwargs):
        Path(fp).write_bytes(b"half a PNG")
        raise OSError("disk full")

    monkeypatch.setattr(Image.Image, "save", failing_save)
    with pytest.raises(OSError, match="disk full"):
        save_image(path, make_frame(1))
    assert path.read_bytes() == before
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("name", ["loop.gif", "movie.mp4"])
def test_video_writers_hold_no_frames_back(tmp_path, name):
    import tracemalloc

    yy, xx = np.mgrid[0:180, 0:320]
    frame = np.stack([xx % 256, yy, (xx + yy) % 256], axis=-1).astype(np.uint8)
    with open_writer(tmp_path / name, fps=30) as out:
        out.write(frame)  # ffmpeg started
        tracemalloc.start()
        for k in range(1, 40):
            out.write(np.roll(frame, 4 * k, axis=1))
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    # each frame made here is one frame's bytes; the writer keeps none of them
    assert peak < 3 * frame.nbytes
