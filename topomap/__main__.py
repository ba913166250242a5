"""``python -m topomap`` runs the command line."""

from topomap.cli.main import run

# guarded: worker processes (the demo's stages side by side) import this module again
if __name__ == "__main__":
    run()
