"""Every Python block of the guides runs, in order, in one namespace per document."""

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from motes.cli.main import RUN_EXAMPLES, _parser
from motes.scene import builtin_scenes

DOCS = Path(__file__).resolve().parents[1] / "docs"
GUIDE = DOCS / "guide.md"


def run_blocks(path: Path) -> dict:
    namespace: dict = {}
    for block in re.findall(r"```python\n(.*?)```", path.read_text(), flags=re.S):
        exec(compile(block, str(path), "exec"), namespace)
    return namespace


@pytest.mark.slow  # the guide compiles most kernels of the library: about 2 minutes
def test_guide_examples_run(capsys):
    blocks = re.findall(r"```python\n(.*?)```", GUIDE.read_text(), flags=re.S)
    assert len(blocks) >= 8
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, str(GUIDE), "exec"), namespace)
    out = capsys.readouterr().out
    assert "contacts" in out


@pytest.mark.slow
def test_rendering_guide_examples_run(capsys):
    namespace = run_blocks(DOCS / "rendering.md")
    assert namespace["image"].shape == (180, 320, 3)
    assert namespace["image"].std() > 5  # ground, crate, ball and blobs: not a flat image
    assert (namespace["out"] / "clip.gif").exists()
    assert "True" in capsys.readouterr().out


@pytest.mark.slow
def test_cloth_guide_examples_run(capsys):
    namespace = run_blocks(DOCS / "cloth.md")
    assert namespace["report"].converged
    assert namespace["x"][1, 2] == 0.0  # restricted to the x-z plane
    assert namespace["hair"].strands().shape == (200, 10, 3)
    assert "True" in capsys.readouterr().out


@pytest.mark.slow  # about a minute from an empty kernel cache; tests/test_fluid*.py cover it
def test_fluids_guide_examples_run(capsys):
    namespace = run_blocks(DOCS / "fluids.md")
    assert namespace["water"].density_error < 0.02
    assert namespace["front"] > 0.15  # the 0.1 m column spread along the tank
    assert len(namespace["pairs"]) > 0
    assert "True" in capsys.readouterr().out


@pytest.mark.slow  # about a minute from an empty kernel cache; tests/test_rigid*.py cover it
def test_rigid_guide_examples_run(capsys):
    namespace = run_blocks(DOCS / "rigid.md")
    assert 0.2 < namespace["centre"][0][1] < 2.1  # the resting crate, then the twisted box
    out = capsys.readouterr().out
    assert "True" in out and "15 31 True" in out
    assert "0.64\n[0. 2.]" in out  # restitution: e² of the drop; a ball passes its velocity on


@pytest.mark.slow
def test_flocks_guide_examples_run(capsys):
    namespace = run_blocks(DOCS / "flocks.md")
    assert namespace["flock"].n == 5_000
    assert not namespace["inside"].any()  # no fish inside the rock
    out = capsys.readouterr().out
    assert "True" in out and out.rstrip().endswith("False")


def test_the_index_links_every_page_and_every_link_resolves():
    index = (DOCS / "index.md").read_text()
    links = {link for link in re.findall(r"\]\(([^)#]+)", index) if "://" not in link}
    pages = {str(page.relative_to(DOCS)) for page in DOCS.rglob("*.md")} - {"index.md"}
    assert pages <= links, f"docs/index.md does not link {sorted(pages - links)}"
    for link in links:
        assert (DOCS / link).exists(), link


# -- commands the docs show ----------------------------------------------------------------
ROOT = DOCS.parent
#: Pages whose commands must work: every doc page and the README (the changelog is
#: history: it quotes commands as they were).
PAGES = [*sorted(DOCS.rglob("*.md")), ROOT / "README.md"]
#: How a command starts: ``motes``, ``.venv/bin/motes``, ``python -m motes``.
PROGRAM = re.compile(r"^(?:\S*/)?(?:motes|python3?\s+-m\s+motes)(?=\s|$)")
#: Placeholders the docs write for a value, and a value of the kind the option wants.
PLACEHOLDERS = {"NAME": "fire", "SCENE": "fire", "SOURCE": "fire", "SEED": "3", "N": "60"}


def doc_commands() -> list[tuple[str, str, bool]]:
    """``(page, command, in_block)`` for every ``motes`` command in code of the docs.

    Shell code blocks hold commands to run; chains (``&&``, ``;``, ``|``) are split, and
    comments and redirections dropped. Inline code may also name a command in passing
    (`motes run`), which ``in_block=False`` marks.
    """
    found = []
    for page in PAGES:
        text = page.read_text()
        name = str(page.relative_to(ROOT))
        for block in re.findall(r"```(?:bash|sh|shell|console)\n(.*?)```", text, flags=re.S):
            for line in block.splitlines():
                line = re.split(r"\s#", line)[0]
                for part in re.split(r"&&|;|\|", line):
                    part = re.split(r"\s\d?>", part)[0].strip()
                    if PROGRAM.match(part):
                        found.append((name, part, True))
        prose = re.sub(r"```.*?```", "", text, flags=re.S)
        for span in re.findall(r"`([^`]+)`", prose):
            span = " ".join(span.split())
            if PROGRAM.match(span):
                found.append((name, span, False))
    for line in RUN_EXAMPLES.splitlines()[1:]:
        found.append(("motes run --help", re.split(r"\s{2,}", line.strip())[0], True))
    return found


def test_the_docs_show_motes_commands():
    commands = doc_commands()
    assert sum(in_block for _, _, in_block in commands) >= 6
    assert {page for page, _, _ in commands} >= {"README.md", "docs/guide.md"}


@pytest.mark.parametrize(("page", "command", "in_block"), doc_commands())
def test_every_motes_command_in_the_docs_parses(page, command, in_block, capsys):
    """Each command's subcommand, options and values exist, and its scene is a built-in."""
    words = shlex.split(PROGRAM.sub("motes", command))[1:]
    words = [PLACEHOLDERS.get(word, word) for word in words]
    if not in_block and len(words) <= 1:
        # A subcommand named in passing ("`motes run` writes ..."): it must exist.
        words += ["--help"]
    try:
        args = _parser().parse_args(words)
    except SystemExit as exit:
        assert exit.code == 0, f"{page}: {command!r}: {capsys.readouterr().err.strip()}"
        return
    scene = getattr(args, "scene", None)
    # (motes view also takes a cache)
    if scene is not None and not scene.endswith((".toml", ".h5", ".npz")):
        assert scene in builtin_scenes(), f"{page}: {command!r}: no built-in scene {scene!r}"


@pytest.mark.slow
def test_the_api_reference_builds(tmp_path):
    """``docs/build.py`` writes a page per public module, rendered from the docstrings."""
    pytest.importorskip("pdoc", reason="the docs extra is not installed")
    result = subprocess.run(
        [sys.executable, str(DOCS / "build.py"), "-o", str(tmp_path)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    assert (tmp_path / "index.html").exists()
    for module in ("motes", "motes/system", "motes/fluids/fluid", "motes/render/renderer"):
        assert (tmp_path / f"{module}.html").exists(), module
    assert not (tmp_path / "motes" / "_jit.html").exists()  # private modules stay out
    page = (tmp_path / "motes" / "system.html").read_text()
    # The class, a parameter from its NumPy-style docstring, and a unit in brackets.
    assert "ParticleSystem" in page and "capacity" in page and "[m/s]" in page


@pytest.mark.slow  # a 64 x 96 x 64 grid for 3 s: about 20 s
def test_grid_fluids_guide_examples_run():
    namespace = run_blocks(DOCS / "grid-fluids.md")
    smoke = namespace["smoke"]
    assert smoke.density.shape == (64, 96, 64)
    assert smoke.density[:, 40:].sum() > 0.1 * smoke.density.sum()  # risen past 2 m
    assert smoke.last_solve.converged
