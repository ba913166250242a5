"""``topomap demo``: the whole pipeline on a generated building."""

from __future__ import annotations

import argparse

from topomap.cli.commands.common import whole_number, worker_count
from topomap.cli.tables import markdown_table


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add the command to the subcommands ``sub``."""
    demo = sub.add_parser("demo", help="run the whole pipeline on a generated building")
    demo.add_argument("--out", default="out/demo")
    demo.add_argument("--size", default="office", choices=["flat", "office", "campus"])
    demo.add_argument("--seed", type=whole_number, default=0)
    demo.add_argument(
        "--jobs",
        type=worker_count,
        default=2,
        help="processes for the stages that run side by side",
    )
    demo.set_defaults(func=cmd_demo)


def cmd_demo(args: argparse.Namespace) -> int:
    from topomap.cli.demo import run_demo, summary_rows

    summary = run_demo(
        args.out, size=args.size, seed=args.seed, jobs=args.jobs, on_stage=args.progress.stage
    )
    print(markdown_table(summary_rows(summary), ["stage", "seconds", "result"]))
    names = summary["segment_plan"]["names"].values()
    print(
        "regions of the plan that are not rooms: "
        + ", ".join(n for n in names if not n.startswith("room "))
    )
    print(f"wrote {args.out}/summary.json (every number) and pictures")
    return 0
