"""``topomap segment``: a map or a laser log into regions."""

from __future__ import annotations

import argparse
import json
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING, Any

from maps.files import OutputFolder, write_text
from topomap.cli.commands.common import (
    DISTANCE,
    KEYFRAME_DISTANCE,
    ONLINE_METHODS,
    SHARE,
    add_bag_options,
    add_output_options,
    add_picture_option,
    add_segmenter_options,
    loading,
    read_as_bag,
    read_keyframes,
    refuse_existing,
    segmenter_options,
    worker_count,
)
from topomap.errors import UsageError

if TYPE_CHECKING:
    from maps.grid import OccupancyGrid
    from maps.scan import Keyframe
    from topomap.topomap import TopoMap


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add the command to the subcommands ``sub``."""
    seg = sub.add_parser("segment", help="segment a map or a laser log into regions")
    source = seg.add_mutually_exclusive_group(required=True)
    source.add_argument(
        "map", nargs="?", help="map_server YAML, a bag's map, or a CARMEN log (as --scans)"
    )
    source.add_argument("--scans", help="CARMEN log or ROS bag instead of a map")
    add_output_options(seg, force="overwrite existing files")
    seg.add_argument(
        "--distance",
        type=DISTANCE,
        help=f"keyframe spacing in a log, m (default {KEYFRAME_DISTANCE})",
    )
    seg.add_argument("--scan-topic")
    seg.add_argument("--pose-topic")
    add_bag_options(seg, map_topic=True)
    add_segmenter_options(seg)
    seg.add_argument(
        "--jobs",
        type=worker_count,
        help="blocks of a large map partitioned this many at a time, in threads (default: one "
        "per core; the regions are the same)",
    )
    seg.add_argument(
        "--online", action="store_true", help="with --scans: assign keyframes as they come"
    )
    seg.add_argument(
        "--online-method",
        default="windows",
        choices=ONLINE_METHODS,
        help="--online: the offline engine on the robot's neighbourhood, or the paper's centres",
    )
    seg.add_argument(
        "--seed-keyframes",
        type=int,
        help="--online: keyframes segmented offline first (default 10%% of the log, at least 40)",
    )
    seg.add_argument(
        "--theta", type=SHARE, default=0.5, help="--online-method centres: acceptance, in [0, 1]"
    )
    seg.add_argument("--frames", type=int, help="a picture every N keyframes and regions.gif")
    seg.add_argument(
        "--previous",
        metavar="DIR",
        help="the output of an earlier map of this building: continued regions keep their ids "
        "(it is laid where its walls fit this map's best: a shift and a turn within 10 degrees)",
    )
    seg.add_argument(
        "--previous-aligned",
        action="store_true",
        help="--previous: the two maps share their frame, lay it as it is",
    )
    add_picture_option(seg, "segmentation.png")
    seg.set_defaults(func=cmd_segment)


def _distance(args: argparse.Namespace) -> float:
    """``--distance``, or :data:`~topomap.cli.commands.common.KEYFRAME_DISTANCE`."""
    return KEYFRAME_DISTANCE if args.distance is None else float(args.distance)


def _options(args: argparse.Namespace) -> dict[str, Any]:
    """The pipeline's options of the command: the segmentation's, its progress and its jobs
    (every core unless ``--jobs``)."""
    jobs = -1 if args.jobs is None else args.jobs
    return {"on_stage": args.progress.stage, "n_jobs": jobs, **segmenter_options(args)}


def cmd_segment(args: argparse.Namespace) -> int:
    with loading():
        from maps.grid import OccupancyGrid
        from maps.scan import select_keyframes
        from segmentation.errors import ParameterError, SegmentationError
        from topomap.cli.drawing import draw_regions
        from topomap.cli.inputs import input_kind
        from topomap.errors import led_by
        from topomap.saving import SAVED
        from topomap.topomap import TopoMap

    if args.map is not None and input_kind(Path(args.map)) == "log":
        args.scans, args.map = args.map, None  # a log's keyframes are the paper's input
    out = Path(args.out)
    source = args.scans if args.scans is not None else args.map
    if args.stamp is not None and (args.map is None or not _bag_map(args)):
        raise UsageError(f"--stamp goes with a bag's map (--map-topic), not {source}")
    if args.distance is not None and args.scans is None:
        raise UsageError(f"--distance spaces a log's keyframes; {source} is a map")
    if args.online:
        if args.jobs is not None:
            raise UsageError("--jobs partitions a large map's blocks, not --online's windows")
        return _segment_online(args, out)
    pictures = [] if args.no_picture else ["segmentation.png"]
    # the planner is prepared by the first `topomap plan --regions` and kept there
    written_names = [*SAVED, "map.yaml", "map.pgm", *pictures, "summary.json"]
    if args.scans is not None:
        written_names.append("keyframes.csv")
    if args.previous is not None:
        written_names.append("changes.json")
    elif args.previous_aligned:
        raise UsageError("--previous-aligned needs --previous DIR")
    refuse_existing(out, written_names, args.force)
    previous = None if args.previous is None else TopoMap.load(args.previous)
    try:
        if args.scans is not None:
            frames = read_keyframes(Path(args.scans), args)
            keyframes = select_keyframes(frames, distance=_distance(args))
            options = _options(args)
            if previous is not None:
                from maps.mapping import grid_from_keyframes

                grid = grid_from_keyframes(keyframes, 0.05)
                topo = _update(previous, args, grid, keyframes, **options)
            else:
                topo = TopoMap.from_keyframes(keyframes, **options)
        else:
            if _bag_map(args):
                from maps.rosbag import read_rosbag_map

                grid = read_rosbag_map(args.map, topic=args.map_topic, stamp=args.stamp)
            else:
                grid = OccupancyGrid.load(args.map)
            options = _options(args)
            topo = (
                TopoMap.from_grid(grid, **options)
                if previous is None
                else _update(previous, args, grid, None, **options)
            )
    except SegmentationError as err:  # the input cannot be segmented: name it
        if isinstance(err, ParameterError) or str(source) in str(err):
            raise
        raise led_by(err, f"{source}: {err}") from err
    folder = OutputFolder(out, written_names, overwrite=args.force, how="--force", last=SAVED[-1])
    count = topo.graph.number_of_nodes()
    # every file appears at once (an interrupted run leaves none); the picture is drawn in a
    # worker thread beside the other files (OpenCV lets it run), which only read ``topo``
    with folder as work, ThreadPoolExecutor(1, "picture") as beside:
        picture = None
        if not args.no_picture:
            args.progress.stage("writing the files and drawing segmentation.png")
            title = f"{Path(source).name}: {count} regions"
            labels, graph = topo.regions.labels, topo.graph
            picture = beside.submit(
                draw_regions, work / "segmentation.png", topo.grid, labels, graph, title=title
            )
        written = topo.save(work, door_graphs=[])
        if args.scans is not None:
            written.append(topo.save_keyframes(work / "keyframes.csv"))
        if picture is not None:
            written.append(picture.result())  # raises what drawing it raised
        summary = _write_summary(work / "summary.json", topo, source, count)
        if previous is not None:
            write_text(work / "changes.json", json.dumps(topo.changes, indent=1))
            written.append(work / "changes.json")
    print(summary)
    print(f"wrote {', '.join(p.name for p in written)}, summary.json to {out}")
    return 0


def _bag_map(args: argparse.Namespace) -> bool:
    """Whether ``segment``'s map is read from a bag (``--map-topic``, or a bag given as it)."""
    return args.map_topic is not None or read_as_bag(Path(args.map))


def _segment_online(args: argparse.Namespace, out: Path) -> int:
    """``topomap segment --scans LOG --online``."""
    from maps.scan import select_keyframes
    from topomap.cli.online import online_outputs, segment_online

    if args.scans is None:
        raise UsageError("--online needs --scans LOG: keyframes arrive one by one from a log")
    if args.previous is not None:
        raise UsageError("--previous is for maps segmented whole, not with --online")
    names = online_outputs(picture=not args.no_picture, frames=bool(args.frames))
    refuse_existing(out, names, args.force)
    args.progress.stage(f"reading {args.scans}")
    keyframes = select_keyframes(read_keyframes(Path(args.scans), args), distance=_distance(args))
    args.progress.stage(f"online segmentation of {len(keyframes)} keyframes")
    summary = segment_online(
        keyframes,
        out,
        source=args.scans,
        seed_keyframes=args.seed_keyframes,
        method=args.online_method,
        theta=args.theta,
        frames_every=args.frames,
        overwrite=args.force,
        picture=not args.no_picture,
        progress=lambda items: args.progress(items, "keyframes"),
        criterion=args.criterion,
        k=args.k,
        p=args.p,
    )
    print(json.dumps(summary, indent=2))
    print(f"wrote {', '.join(summary['written'])}, summary.json to {out}")
    return 0


def _write_summary(path: Path, topo: Any, source: str, count: int) -> str:
    """Write ``summary.json`` of ``topomap segment``; returns its text."""
    summary = {
        "source": str(source),
        "regions": count,
        "spectral_clusters": topo.segmenter.n_regions_,
        "keyframes": len(topo.keyframes),
        "conditioning": topo.conditioned.summary(),
        "coverage": {
            "filled_cells": topo.found.coverage.filled_cells,
            "rooms_seen_through_doors": topo.found.coverage.seen_rooms,
            "pockets_joined": topo.found.coverage.pockets,
        },
        "doors": sum(len(d) for _, _, d in topo.graph.edges(data="doors")),
        "names": {int(r): name for r, name in sorted(topo.graph.nodes(data="name"))},
        "silhouette_by_k": {
            str(k): round(v, 4) for k, v in topo.segmenter.silhouette_by_k_.items()
        },
        "seconds": {k: round(v, 3) for k, v in topo.seconds.items()},
    }
    if topo.placement is not None:  # --previous: where the previous map was laid
        summary["previous_placement"] = topo.placement.as_dict()
    text = json.dumps(summary, indent=2)
    write_text(path, text)
    return text


def _update(
    previous: TopoMap,
    args: argparse.Namespace,
    grid: OccupancyGrid,
    keyframes: list[Keyframe] | None,
    **options: Any,
) -> TopoMap:
    """``previous.update``, its refusal naming the ``--previous`` folder; where the previous
    map was laid said on stderr when that moves it by more than a cell."""
    from segmentation.growing import MapMismatchError

    try:
        topo = previous.update(grid, keyframes, aligned=args.previous_aligned, **options)
    except MapMismatchError as err:
        raise MapMismatchError(f"--previous {args.previous}: {err}") from None
    placement = topo.placement
    if placement is not None and placement.largest_shift(previous.grid) > grid.resolution:
        print(f"--previous {args.previous}: laid on this map {placement}", file=sys.stderr)
    return topo
