"""``topomap eval``: segmentation and labels against ground truth."""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from maps.files import write_text
from topomap.cli.commands.common import (
    RESOLUTION,
    add_output_options,
    add_segmenter_options,
    refuse_existing,
    segmenter_options,
    worker_count,
)
from topomap.cli.tables import markdown_table


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add the command to the subcommands ``sub``."""
    evaluation = sub.add_parser("eval", help="evaluations against ground truth")
    eval_sub = evaluation.add_subparsers(dest="evaluation", required=True)
    eval_seg = eval_sub.add_parser(
        "segment", help="room segmentation against people's rooms (ipa plans, ROSE² maps)"
    )
    eval_seg.add_argument(
        "data", help="folder of map YAMLs with *_gt_labels.png, or of maps/ and gt/ (ROSE²)"
    )
    add_output_options(eval_seg, "out/eval-segment")
    eval_seg.add_argument(
        "--shifts",
        action="store_true",
        help="also segment every map moved one cell right, down and both; scores are the means "
        "over the four (mcc_spread: their largest MCC minus the smallest)",
    )
    eval_seg.add_argument(
        "--rotations",
        action="store_true",
        help="also segment every map turned 3, 17, 30 and 45 degrees against the cell grid (its "
        "people's rooms turned alike), and turned and turned back (turned_back: what the "
        "turning's resampling costs alone); each scored apart",
    )
    eval_seg.add_argument(
        "--resolutions",
        action="store_true",
        help="also segment every map on cells twice as large (as a mapper would make them: "
        "occupied where a beam ended, free where one passed) and half as large, its people's "
        "rooms alike; each scored apart (cell_factor)",
    )
    eval_seg.add_argument(
        "--thicker",
        action="store_true",
        help="also segment every map with its walls a cell thicker on every side (as a mapper "
        "with more range noise draws them: doors and corridors two cells narrower), its "
        "people's rooms without those cells; scored apart (grown_walls)",
    )
    eval_seg.add_argument(
        "--half-cell",
        action="store_true",
        help="also segment every map as a mapper whose cells fall half a cell over draws it "
        "(each cell split in four, moved one, merged again as a mapper would: walls a cell "
        "wider where they fall across cells, and every ray two cells wide, harsher than a real "
        "mapper), its people's rooms alike; scored apart (half_cell_over)",
    )
    add_segmenter_options(eval_seg, method=False)
    eval_seg.set_defaults(func=cmd_eval_segment)

    eval_labels = eval_sub.add_parser(
        "labels", help="region labels on labelled buildings, whole buildings left out"
    )
    eval_labels.add_argument("data", help="folder of NAME.png with NAME_places.png (ipa_places)")
    eval_labels.add_argument("--rose2", metavar="DIR", help="ROSE²'s maps (rose2_partial)")
    eval_labels.add_argument("--carmen", metavar="DIR", help="folder of the four CARMEN logs")
    eval_labels.add_argument(
        "--generated", action="store_true", help="also generated buildings (plans and scanned)"
    )
    _add_hand_labels(eval_labels, "rose2_partial.csv and carmen.json: the room types")
    add_output_options(eval_labels, "out/eval-labels")
    eval_labels.add_argument(
        "--save-model", metavar="SKOPS", help="write a forest trained on all labelled regions"
    )
    eval_labels.set_defaults(func=cmd_eval_labels)

    for name, helping, drawn, func in (
        (
            "corridors",
            "corridor systems drawn on the real logs' maps against the regions of their "
            "keyframes: one region each",
            "carmen.json: the corridors",
            cmd_eval_corridors,
        ),
        (
            "logs",
            "rooms drawn on the real logs' maps against the regions of their keyframes and of "
            "their maps alone (keyframe ARI, MCC, IoU), both methods",
            "carmen_rooms.json: the rooms",
            cmd_eval_logs,
        ),
    ):
        on_logs = eval_sub.add_parser(name, help=helping)
        on_logs.add_argument("data", help="folder of the CARMEN logs")
        on_logs.add_argument(
            "--resolution",
            type=RESOLUTION,
            default=0.05,
            help="cell size of the maps built from the logs, metres (as topomap map --resolution)",
        )
        _add_hand_labels(on_logs, drawn)
        add_output_options(on_logs, f"out/eval-{name}")
        on_logs.set_defaults(func=func)

    eval_runs = eval_sub.add_parser(
        "runs",
        help="a simulated robot's runs through generated buildings: the regions of its own "
        "keyframes against the rooms (MCC, keyframe ARI)",
    )
    eval_runs.add_argument(
        "--sizes",
        type=building_sizes,
        default="flat,office",
        help="building sizes, comma-separated (flat, office, campus)",
    )
    eval_runs.add_argument("--seeds", type=worker_count, default=4, help="runs per size")
    eval_runs.add_argument(
        "--fov",
        type=field_of_view,
        default=180,
        help="the robot's laser's field of view, degrees (a beam a degree; 360: a lidar)",
    )
    add_output_options(eval_runs, "out/eval-runs")
    add_segmenter_options(eval_runs, method=False)
    eval_runs.set_defaults(func=cmd_eval_runs)


def building_sizes(text: str) -> list[str]:
    """``--sizes``: generated buildings' sizes, comma-separated (an argparse type).

    Examples
    --------
    >>> building_sizes("flat, office,flat")
    ['flat', 'office']
    """
    from maps.sim.floorplan import SIZES

    sizes = list(dict.fromkeys(size.strip() for size in text.split(",") if size.strip()))
    if not sizes:
        raise argparse.ArgumentTypeError(f"no building size given; known: {', '.join(SIZES)}")
    unknown = sorted(set(sizes) - set(SIZES))
    if unknown:
        raise argparse.ArgumentTypeError(
            f"unknown building size(s) {unknown}; known: {', '.join(SIZES)}"
        )
    return sizes


def field_of_view(text: str) -> int:
    """``--fov``: a laser's field of view, whole degrees in 2..360 (an argparse type).

    Examples
    --------
    >>> field_of_view("270")
    270
    """
    if not text.isdigit() or not 2 <= int(text) <= 360:
        raise argparse.ArgumentTypeError(f"must be whole degrees in 2..360, got {text!r}")
    return int(text)


#: The hand-drawn labels kept with the repository (not installed with the package).
HAND_LABELS = Path(__file__).resolve().parents[3] / "tests" / "data" / "labels"


def _add_hand_labels(parser: argparse.ArgumentParser, what: str) -> None:
    """``--hand-labels DIR``: the folder of the files ``what`` names, drawn by hand (by
    default the repository's, wherever the command is run from)."""
    parser.add_argument(
        "--hand-labels",
        default=str(HAND_LABELS),
        metavar="DIR",
        help=f"{what} drawn by hand (default: the repository's tests/data/labels)",
    )


def cmd_eval_segment(args: argparse.Namespace) -> int:
    from topomap.cli.evaluate import (
        CELL_FACTORS,
        GROWN_WALLS,
        ROTATIONS,
        SHIFTS,
        evaluate_all,
        means,
        read_anchors,
    )

    out = Path(args.out)
    refuse_existing(out, ["results.json"], args.force)
    shifts = SHIFTS if args.shifts else ((0, 0),)
    rotations = ROTATIONS if args.rotations else (0.0,)
    options = segmenter_options(args)
    anchors = read_anchors(args.data)  # a malformed file refused before the maps are segmented
    records = evaluate_all(
        args.data,
        progress=args.progress,
        shifts=shifts,
        rotations=rotations,
        cell_factors=CELL_FACTORS if args.resolutions else (1.0,),
        grown_walls=GROWN_WALLS if args.thicker else (0,),
        half_cells=(False, True) if args.half_cell else (False,),
        **options,
    )
    turns = (
        (["rotation", "turned_back"] if args.rotations else [])
        + (["cell_factor"] if args.resolutions else [])
        + (["grown_walls"] if args.thicker else [])
        + (["half_cell_over"] if args.half_cell else [])
    )
    columns = ["map", "furnished", "variant", *turns, "segments", "rooms"]
    columns += ["recall", "precision", "mcc"]
    columns += ["mcc_spread"] if args.shifts else []
    columns += ["ari", "rose2_precision", "rose2_recall", "rose2_iou", "seconds"]
    print(markdown_table(records, columns))
    print()
    summary = means(records, anchors)
    print(
        markdown_table(
            summary,
            [
                *["method", "furnished", *turns, "maps", "recall", "precision", "mcc", "min_mcc"],
                *(["mcc_spread"] if args.shifts else []),
                "ari",
                *["rose2_precision", "rose2_recall", "rose2_iou", "mean_s", "max_s"],
            ],
        )
    )
    text = json.dumps({"maps": records, "means": summary}, indent=2)
    write_text(out / "results.json", text, overwrite=args.force)
    print(f"wrote {out / 'results.json'}")
    return 0


def cmd_eval_labels(args: argparse.Namespace) -> int:
    from topomap.cli.label_report import run

    refuse_existing(Path(args.out), ["results.json"], args.force)
    run(args)
    return 0


def cmd_eval_corridors(args: argparse.Namespace) -> int:
    from topomap.cli.evaluate_corridors import evaluate_corridors

    columns = ["log", "regions", "largest_share", "best_iou", "pieces"]
    return _report_logs(args, evaluate_corridors, "carmen.json", columns)


def cmd_eval_logs(args: argparse.Namespace) -> int:
    from topomap.cli.evaluate_logs import evaluate_logs

    columns = ["log", "method", "input", "keyframes", "regions", "rooms", "keyframe_ari"]
    return _report_logs(args, evaluate_logs, "carmen_rooms.json", [*columns, "mcc", "rose2_iou"])


def _report_logs(
    args: argparse.Namespace,
    evaluate: Callable[..., list[dict[str, Any]]],
    drawn: str,
    columns: list[str],
) -> int:
    """``evaluate`` the logs of ``args.data`` against the hand labels' ``drawn`` file: the
    records as a table of ``columns`` and in ``results.json``."""
    out = Path(args.out)
    refuse_existing(out, ["results.json"], args.force)
    records = evaluate(
        args.data,
        Path(args.hand_labels) / drawn,
        progress=args.progress,
        resolution=args.resolution,
    )
    print(markdown_table(records, columns))
    write_text(out / "results.json", json.dumps({"logs": records}, indent=2), overwrite=args.force)
    print(f"wrote {out / 'results.json'}")
    return 0


def cmd_eval_runs(args: argparse.Namespace) -> int:
    from maps.sim.survey import SURVEY_LASER
    from topomap.cli.evaluate_runs import evaluate_runs, run_means

    out = Path(args.out)
    refuse_existing(out, ["results.json"], args.force)
    records = evaluate_runs(
        args.sizes,
        range(args.seeds),
        progress=args.progress,
        laser=replace(SURVEY_LASER, fov=math.radians(args.fov), beams=min(args.fov + 1, 360)),
        **segmenter_options(args),
    )
    columns = ["size", "seed", "method", "keyframes", "regions", "rooms", "mcc", "recall"]
    print(markdown_table(records, [*columns, "precision", "keyframe_ari"]))
    print()
    summary = run_means(records)
    print(markdown_table(summary, ["size", "method", "runs", "mcc", "min_mcc", "keyframe_ari"]))
    text = json.dumps({"runs": records, "means": summary}, indent=2)
    write_text(out / "results.json", text, overwrite=args.force)
    print(f"wrote {out / 'results.json'}")
    return 0
