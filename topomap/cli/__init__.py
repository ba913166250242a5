"""The tools around the library: the ``topomap`` command line, the demo, benchmarks,
evaluations and pictures. Nothing in the library packages imports from here."""

from topomap.cli.main import main, run

__all__ = ["main", "run"]
