"""Outputs record how they were made: writers store metadata, read_metadata reads it
back, and ``motes run`` records the scene, its source, the seed and the motes version."""

import json

import numpy as np
import pytest

import motes
from motes.cli import main
from motes.io import open_writer, read_metadata
from motes.io.frames import SequenceWriter

# Characters ffmpeg's metadata format escapes, a newline, and text beyond Latin-1.
AWKWARD = {"scene": "a=b;c#d\\e\nf", "source": "/tmp/scènes/ünïcode ✓.toml", "seed": "7"}


@pytest.mark.parametrize("name", ["still.png", "loop.gif", "movie.mp4", "frames/"])
def test_every_writer_stores_metadata_that_reads_back_exactly(tmp_path, name):
    path = tmp_path / name
    with open_writer(path, fps=10, metadata=AWKWARD) as out:
        for k in range(3):
            out.write(np.full((16, 24, 3), 40 * k, np.uint8))
    record = read_metadata(path)
    assert {k: record[k] for k in AWKWARD} == AWKWARD
    if name == "frames/":
        assert (record["frames"], record["prefix"], record["start"]) == (3, "frame_", 0)


def test_without_metadata_or_frames_there_is_no_record(tmp_path):
    for name in ("plain.png", "plain/"):
        path = tmp_path / name
        with open_writer(path) as out:
            out.write(np.zeros((4, 4, 3), np.uint8))
        assert read_metadata(path) == {}
    assert sorted(p.name for p in (tmp_path / "plain").iterdir()) == ["frame_00000.png"]
    empty = tmp_path / "empty"
    SequenceWriter(empty, metadata={"scene": "x"}).close()
    assert list(empty.iterdir()) == [] and read_metadata(empty) == {}


@pytest.mark.parametrize(
    ("metadata", "error"),
    [({"bad key": "x"}, ValueError), ({"seed": 7}, TypeError), (["seed"], TypeError)],
)
def test_bad_metadata_is_refused(tmp_path, metadata, error):
    with pytest.raises(error, match="metadata"):
        open_writer(tmp_path / "x.png", metadata=metadata)


SCENE = """
[scene]
name = "tiny"
fps = 10
seed = 5
[camera]
resolution = [32, 18]
[[system]]
name = "a"
  [[system.emitter]]
  rate = { type = "per_second", rate = 100 }
"""


@pytest.mark.parametrize("name", ["tiny.mp4", "tiny.png", "seq/"])
def test_motes_run_records_the_scene_source_seed_and_version(tmp_path, name, capsys):
    source = tmp_path / "tiny.toml"
    source.write_text(SCENE)
    out = tmp_path / name
    assert main(["run", str(source), "-o", str(out), "--frames", "2", "--seed", "9", "-q"]) == 0
    record = read_metadata(out)
    assert record["scene"] == "tiny"
    assert record["source"] == str(source)
    assert record["seed"] == "9"  # the seed the run used: --seed over the file's
    assert record["motes_version"] == motes.__version__
    if name == "seq/":
        assert json.loads((out / "frames.json").read_text())["frames"] == 2
