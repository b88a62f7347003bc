"""The worlds this plugin gives: each a module attribute holding a world file's path, named by an entry point."""

from pathlib import Path

GREENHOUSE = Path(__file__).parent / "greenhouse.yaml"
"""A long room with a lamp at its east end: ``atlas run --world greenhouse``."""
