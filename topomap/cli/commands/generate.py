"""``topomap generate``: a generated building, its map and its true rooms."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from maps.files import OutputFolder, write_text
from maps.limits import MAX_FURNITURE
from topomap.cli.commands.common import (
    RESOLUTION,
    add_output_options,
    number_type,
    refuse_existing,
    whole_number,
)

FURNITURE = number_type(0.0, MAX_FURNITURE, unit="blocks per 10 m^2")


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add the command to the subcommands ``sub``."""
    gen = sub.add_parser("generate", help="generate a building: map YAML + ground-truth rooms")
    gen.add_argument("--size", default="office", choices=["flat", "office", "campus"])
    gen.add_argument("--seed", type=whole_number, default=0)
    gen.add_argument("--resolution", type=RESOLUTION, default=0.05)
    gen.add_argument(
        "--furniture", type=FURNITURE, default=0.0, help="blocks per 10 m^2 (at most 10)"
    )
    add_output_options(gen, force="overwrite existing map files")
    gen.set_defaults(func=cmd_generate)


def cmd_generate(args: argparse.Namespace) -> int:
    from maps.sim.floorplan import generate_floor_plan
    from segmentation.export import write_label_image

    out = Path(args.out)
    names = ["map.yaml", "map.pgm", "rooms.png", "rooms.json"]
    refuse_existing(out, names, args.force)
    args.progress.stage(f"generating a {args.size} building")
    plan = generate_floor_plan(
        args.size, resolution=args.resolution, furniture=args.furniture, random_state=args.seed
    )
    with OutputFolder(out, names, overwrite=args.force, how="--force") as work:
        plan.grid.save(work / "map.yaml")
        write_label_image(plan.labels, work / "rooms.png")
        rooms = [{"id": i, "type": t} for i, t in enumerate(plan.types, start=1)]
        write_text(work / "rooms.json", json.dumps(rooms, indent=1))
    print(f"{plan.n_rooms} spaces, {len(plan.doors)} doors -> {out}")
    return 0
