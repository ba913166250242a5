"""``python -m topomap`` runs the command line."""

from topomap.cli import run

run()
