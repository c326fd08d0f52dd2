"""The ``motes`` command line: thin; every command is a call into the library."""

from .main import main

__all__ = ["main"]
