"""``topomap batch``: many maps, logs and bags segmented on a Dask cluster."""

from __future__ import annotations

import argparse

from topomap.cli.commands.common import (
    DISTANCE,
    KEYFRAME_DISTANCE,
    RESOLUTION,
    add_bag_options,
    add_output_options,
    add_segmenter_options,
    segmenter_options,
    worker_count,
)
from topomap.cli.tables import markdown_table


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add the command to the subcommands ``sub``."""
    batch = sub.add_parser("batch", help="segment many maps, logs and bags on a Dask cluster")
    batch.add_argument("inputs", nargs="+", help="map YAMLs, logs, bags, folders or globs")
    add_output_options(
        batch,
        force="redo inputs already done",
        where="one folder per input, index.csv, summary.json",
    )
    batch.add_argument("--workers", type=worker_count, default=2, help="local worker processes")
    batch.add_argument("--scheduler", help="address of a running Dask scheduler (tcp://host:8786)")
    batch.add_argument(
        "--distance", type=DISTANCE, default=KEYFRAME_DISTANCE, help="keyframe spacing in a log, m"
    )
    batch.add_argument("--resolution", type=RESOLUTION, default=0.05, help="maps from logs, m/cell")
    batch.add_argument("--scan-topic")
    add_bag_options(batch, map_topic=True)
    add_segmenter_options(batch)
    batch.set_defaults(func=cmd_batch)


def cmd_batch(args: argparse.Namespace) -> int:
    from topomap.cli.batch import BatchOptions, check_batch, dask_client, run_batch, tqdm_bar

    options = BatchOptions(
        distance=args.distance,
        resolution=args.resolution,
        scan_topic=args.scan_topic,
        fixed_frame=args.fixed_frame,
        map_topic=args.map_topic,
        stamp=args.stamp,
        segmenter=segmenter_options(args),
    )
    # a bad input, output folder or address stops the command before a cluster starts
    check_batch(args.inputs, args.out, force=args.force, scheduler=args.scheduler)
    bar = None if getattr(args, "quiet", False) else tqdm_bar
    with dask_client(args.workers, args.scheduler) as client:
        records = run_batch(
            args.inputs, args.out, client=client, force=args.force, options=options, progress=bar
        )
    print(markdown_table(records, ["name", "status", "regions", "keyframes", "seconds", "error"]))
    statuses = [r["status"] for r in records]
    print(
        f"{statuses.count('ok')} done, {statuses.count('skipped')} skipped (done before), "
        f"{statuses.count('failed')} failed; wrote {args.out}/index.csv and summary.json"
    )
    return 1 if "failed" in statuses else 0
