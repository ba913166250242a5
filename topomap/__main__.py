"""``python -m topomap`` runs the command line."""

from topomap.cli import main

raise SystemExit(main())
