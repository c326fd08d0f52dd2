"""``python -m motes`` runs the command line (same as the ``motes`` script)."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
