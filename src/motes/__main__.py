"""Command line: ``python -m motes demo`` (or the ``motes`` script)."""

from __future__ import annotations

import argparse
import sys


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="motes", description="motes particle systems")
    parser.add_argument("--version", action="store_true", help="print the version and exit")
    sub = parser.add_subparsers(dest="command")
    demo = sub.add_parser("demo", help="simulate a fire for 10 s and print a summary")
    demo.add_argument("--seconds", type=float, default=10.0, help="simulated time [s]")
    demo.add_argument("--seed", type=int, default=1, help="random seed")
    demo.add_argument("--rate", type=float, default=2000.0, help="mean births per frame")
    args = parser.parse_args(argv)
    if args.version:
        from . import __version__

        print(f"motes {__version__}")
        return 0
    if args.command != "demo":
        parser.print_help()
        return 0
    from .demo import run

    try:
        run(args.seconds, seed=args.seed, rate=args.rate)
    except (ValueError, TypeError) as err:
        print(f"motes: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("motes: interrupted", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
