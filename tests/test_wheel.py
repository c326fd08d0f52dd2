"""A built wheel holds what motes reads at run time, and runs from a fresh environment.

Users install a wheel, not the checkout: this builds one from the repository, installs it
into a new virtual environment outside the checkout, and runs ``motes scenes`` and a
built-in scene from there. The new environment borrows the test environment's NumPy,
Numba, Pillow and imageio-ffmpeg through a path file (no download), but motes itself comes
only from the wheel (asserted). The scene runs with ``NUMBA_DISABLE_JIT=1``: compiling every
kernel afresh in the new location would cost a minute and prove nothing about packaging.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import venv
import zipfile
from pathlib import Path

import numpy as np
from PIL import Image

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "motes"


def _run(*args, cwd, env=None) -> str:
    done = subprocess.run(
        [str(a) for a in args], cwd=cwd, env=env, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, f"{args} failed:\n{done.stdout}\n{done.stderr}"
    return done.stdout


def _source_copy(out: Path) -> Path:
    """The repository's files as a clean checkout has them (no build leftovers such as an
    ``egg-info`` whose file list would hide a missing package-data rule)."""
    listed = _run("git", "ls-files", "-co", "--exclude-standard", "-z", cwd=ROOT)
    copy = out / "source"
    for name in filter(None, listed.split("\0")):
        source = ROOT / name
        if source.is_file():
            (copy / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, copy / name)
    return copy


def _build_wheel(out: Path) -> Path:
    # --no-build-isolation: the test environment's setuptools builds it, offline.
    _run(
        sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation",
        "-w", out, _source_copy(out), cwd=out,
    )  # fmt: skip
    (wheel,) = out.glob("motes-*.whl")
    return wheel


def _runtime_files() -> set[str]:
    """Every non-Python file in the package: motes reads each of them at run time."""
    return {
        p.relative_to(PACKAGE.parent).as_posix()
        for p in PACKAGE.rglob("*")
        if p.is_file() and p.suffix not in (".py", ".pyc", ".nbi", ".nbc")
    }


def test_the_wheel_holds_every_runtime_file_and_runs_from_a_fresh_environment(tmp_path):
    wheel = _build_wheel(tmp_path)
    with zipfile.ZipFile(wheel) as archive:
        held = set(archive.namelist())
    wanted = _runtime_files()
    assert any(name.endswith("builtin/fire.toml") for name in wanted)
    assert wanted <= held, f"missing from the wheel: {sorted(wanted - held)}"

    fresh = tmp_path / "fresh"
    venv.create(fresh, with_pip=False)
    python = fresh / "bin" / "python"
    _run(sys.executable, "-m", "pip", "--python", python, "install", "-q", "--no-deps", wheel,
         cwd=tmp_path)  # fmt: skip
    # The dependencies (never motes: a path entry in a .pth file does not run the
    # editable install's own .pth) come from the test environment's site-packages.
    site = Path(_run(python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])",
                     cwd=tmp_path).strip())  # fmt: skip
    (site / "_motes_test_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")

    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "NUMBA"))}
    env["NUMBA_DISABLE_JIT"] = "1"
    where = _run(python, "-c", "import motes; print(motes.__file__)", cwd=tmp_path, env=env)
    assert Path(where.strip()).is_relative_to(fresh)

    motes = fresh / "bin" / "motes"
    listed = _run(motes, "scenes", cwd=tmp_path, env=env).splitlines()
    names = {line.split()[0] for line in listed}
    assert {p.stem for p in (PACKAGE / "scene" / "builtin").glob("*.toml")} == names

    _run(motes, "run", "fire", "--frames", "2", "--resolution", "32x18", "-o", "fire.png",
         "--quiet", cwd=tmp_path, env=env)  # fmt: skip
    image = np.asarray(Image.open(tmp_path / "fire.png"))
    assert image.shape == (18, 32, 3) and image.max() > 0
