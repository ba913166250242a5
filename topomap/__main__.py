"""``python -m topomap`` runs the command line."""

from topomap.cli.main import run

run()
