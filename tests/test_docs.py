"""Every Python block of the guides runs, in order, in one namespace per document."""

import re
from pathlib import Path

DOCS = Path(__file__).resolve().parents[1] / "docs"
GUIDE = DOCS / "guide.md"


def run_blocks(path: Path) -> dict:
    namespace: dict = {}
    for block in re.findall(r"```python\n(.*?)```", path.read_text(), flags=re.S):
        exec(compile(block, str(path), "exec"), namespace)
    return namespace


def test_guide_examples_run(capsys):
    blocks = re.findall(r"```python\n(.*?)```", GUIDE.read_text(), flags=re.S)
    assert len(blocks) >= 8
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, str(GUIDE), "exec"), namespace)
    out = capsys.readouterr().out
    assert "contacts" in out


def test_rendering_guide_examples_run(capsys):
    namespace = run_blocks(DOCS / "rendering.md")
    assert namespace["image"].shape == (180, 320, 3)
    assert namespace["image"].std() > 5  # ground, crate, ball and blobs: not a flat image
    assert (namespace["out"] / "clip.gif").exists()
    assert "True" in capsys.readouterr().out


def test_cloth_guide_examples_run(capsys):
    namespace = run_blocks(DOCS / "cloth.md")
    assert namespace["report"].converged
    assert namespace["x"][1, 2] == 0.0  # restricted to the x-z plane
    assert namespace["hair"].strands().shape == (200, 10, 3)
    assert "True" in capsys.readouterr().out


def test_fluids_guide_examples_run(capsys):
    namespace = run_blocks(DOCS / "fluids.md")
    assert namespace["water"].density_error < 0.02
    assert namespace["front"] > 0.15  # the 0.1 m column spread along the tank
    assert len(namespace["pairs"]) > 0
    assert "True" in capsys.readouterr().out


def test_rigid_guide_examples_run(capsys):
    namespace = run_blocks(DOCS / "rigid.md")
    assert 0.2 < namespace["centre"][0][1] < 2.1  # the resting crate, then the twisted box
    out = capsys.readouterr().out
    assert "True" in out and "15 31 True" in out
    assert "0.64\n[0. 2.]" in out  # restitution: e² of the drop; a ball passes its velocity on
