"""``topomap view``: one self-contained HTML page of a map."""

from __future__ import annotations

import argparse

from topomap.cli.commands.common import RADIUS, add_output_options, whole_number


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add the command to the subcommands ``sub``."""
    view = sub.add_parser("view", help="one self-contained HTML page of a map, for a browser")
    view.add_argument("regions", help="folder written by `topomap segment`")
    add_output_options(view, force="overwrite an existing file", where="OUT.html")
    view.add_argument("--robot-radius", type=RADIUS, default=0.2, help="metres")
    view.add_argument(
        "--max-paths",
        type=whole_number,
        default=400,
        help="plan every pair of regions up to this many pairs, else neighbours' legs",
    )
    view.set_defaults(func=cmd_view)


def cmd_view(args: argparse.Namespace) -> int:
    from topomap.cli.viewer import run_view

    return run_view(args)
