"""Build the API reference: one HTML page per public module of motes, from its docstrings.

    python docs/build.py [-o site/api]

Needs the ``docs`` extra (``python -m pip install -e ".[docs]"``): pdoc, which imports
each module and renders its docstrings as NumPy style. Open ``site/api/index.html`` in a
browser; it has a search box. Modules whose name starts with ``_`` are private and left
out, as pdoc does by default.
"""

from __future__ import annotations

import argparse
import pkgutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_OUTPUT = ROOT / "site" / "api"


def public_modules() -> list[str]:
    """``motes`` and every module under it with no part of its name starting with ``_``.

    Listed here because pdoc, given a package with ``__all__``, follows only the
    submodules that ``__all__`` names.
    """
    import motes

    names = ["motes"]
    for module in pkgutil.walk_packages(motes.__path__, "motes."):
        if not any(part.startswith("_") for part in module.name.split(".")):
            names.append(module.name)
    return names


def build(output: Path = DEFAULT_OUTPUT) -> Path:
    """Write the reference of ``motes`` into ``output``; return its ``index.html``."""
    try:
        import pdoc
        import pdoc.extract
        import pdoc.render
    except ImportError:
        raise SystemExit('docs/build.py needs pdoc: python -m pip install -e ".[docs]"') from None
    # A checkout that is not installed builds from its own sources.
    source = ROOT / "src"
    if (source / "motes").is_dir() and str(source) not in sys.path:
        sys.path.insert(0, str(source))
    pdoc.render.configure(
        docformat="numpy",
        footer_text="motes API reference",
        template_directory=ROOT / "docs" / "api_templates",
    )
    # pdoc takes each name with the submodules it finds under it: name each module once.
    specs, covered = [], set()
    for name in public_modules():
        if name not in covered:
            specs.append(name)
            covered.update(pdoc.extract.walk_specs([name]))
    # Leave out the private modules pdoc found under packages without ``__all__``.
    pdoc.pdoc(*specs, r"!(.*\.)?_", output_directory=Path(output))
    return Path(output) / "index.html"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "-o", "--output", type=Path, default=DEFAULT_OUTPUT, help="folder (default: site/api)"
    )
    index = build(parser.parse_args(argv).output)
    print(f"wrote {index}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
