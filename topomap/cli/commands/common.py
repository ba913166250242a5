"""What the commands share: option types, input readers, output checks, tables."""

from __future__ import annotations

import argparse
import gc
import math
import sys
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from maps.errors import LogFormatError
from maps.files import check_outputs
from maps.limits import MAX_LENGTH, MAX_ROBOT_RADIUS, RESOLUTION_RANGE, finite_in
from topomap.errors import UsageError

#: The online segmenters: the offline engine on windows (default), the paper's centres.
ONLINE_METHODS = ("windows", "centres")

#: Whether the command runs in a process of its own, the console script's
#: (:func:`topomap.cli.main.run` sets it): then :func:`loading` freezes what imports made.
FREEZE_IMPORTS = False


@contextmanager
def loading() -> Iterator[None]:
    """Within: a command's imports, without the cyclic garbage collector. Loading NumPy,
    SciPy, OpenCV and networkx makes some 110,000 objects that live as long as the process;
    the collector ran 175 times over them (40 ms of ``topomap segment``). In the console
    script's process (:data:`FREEZE_IMPORTS`) they are then frozen (:func:`gc.freeze`: left
    out of every later collection); elsewhere the collector meets them later as usual."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if FREEZE_IMPORTS:
            gc.freeze()
        if enabled:
            gc.enable()


def refuse_existing(out: Path, names: Iterable[str], force: bool) -> None:
    """Stop before any work when a file the command would write exists and ``--force`` is
    not given, or when ``out`` or a file in it cannot be written (a file in the place of the
    folder, a folder in the place of a file)."""
    check_outputs(out, names, overwrite=force, how="--force")


def read_keyframes(source: Path, args: argparse.Namespace) -> list:
    """The scans of a CARMEN log or a ROS bag (by :func:`read_as_bag`)."""
    from maps.carmen import read_carmen
    from maps.rosbag import read_bag_scans

    if not read_as_bag(source):
        given = (("--scan-topic", args.scan_topic), ("--pose-topic", args.pose_topic))
        topics = " and ".join(flag for flag, value in given if value)
        if topics:
            raise UsageError(f"{topics} name a bag's topics; {source} is a CARMEN log")
        return read_carmen(source)
    found = read_bag_scans(
        source, scan_topic=args.scan_topic, pose_topic=args.pose_topic, fixed_frame=args.fixed_frame
    )
    print(f"{source}: {found.describe()}", file=sys.stderr)
    return found.keyframes


def read_as_bag(source: Path) -> bool:
    """A bag (:func:`topomap.cli.inputs.is_bag`), or a folder named as one: the bag reader
    then says what it lacks."""
    from topomap.cli.inputs import is_bag

    try:
        return source.is_dir() or is_bag(source)
    except OSError as err:  # a folder on the way that may not be looked into
        raise LogFormatError(f"cannot be read ({err.strerror or err})", path=source) from None


def add_bag_options(parser: argparse.ArgumentParser, *, map_topic: bool) -> None:
    """``--fixed-frame`` for scans in bags (and ``--map-topic``, ``--stamp`` for their maps)."""
    parser.add_argument(
        "--fixed-frame",
        type=frame_name,
        help="place bag scans in this tf frame (default: map, else odom)",
    )
    if map_topic:
        parser.add_argument(
            "--map-topic", help="segment the bag's nav_msgs/OccupancyGrid on this topic"
        )
        parser.add_argument(
            "--stamp", type=STAMP, help="with --map-topic: the last map at or before this time, s"
        )


def frame_name(text: str) -> str:
    """``--fixed-frame``: a tf frame name that is not empty.

    An argparse type, so an empty name is a usage error before any work.
    """
    from maps.tf import frame_problem

    problem = frame_problem(text)
    if problem is not None:
        raise argparse.ArgumentTypeError(problem)
    return text


def add_output_options(
    parser: argparse.ArgumentParser,
    out: str | None = None,
    *,
    where: str | None = None,
    force: str = "overwrite existing results",
) -> None:
    """``--out`` (required unless ``out`` is its default; ``where``: its help) and
    ``--force`` (``force``: its help)."""
    parser.add_argument("--out", type=output_path, required=out is None, default=out, help=where)
    parser.add_argument("--force", action="store_true", help=force)


def output_path(text: str) -> str:
    """``--out``: a path that is not empty (an empty one would write into the current folder).

    An argparse type, so an empty path is a usage error before any work.
    """
    if not text.strip():
        raise argparse.ArgumentTypeError(f"an output path cannot be empty, got {text!r}")
    return text


def add_picture_option(parser: argparse.ArgumentParser, picture: str) -> None:
    """``--no-picture``: skip drawing ``picture`` (matplotlib), for scripts and batches."""
    parser.add_argument("--no-picture", action="store_true", help=f"do not draw {picture} (faster)")


def segmenter_options(args: argparse.Namespace) -> dict[str, Any]:
    """The segmentation options of ``topomap segment``, ``eval segment``, ``eval runs`` and
    ``batch`` (``method`` where the command has ``--method``)."""
    options = {
        "criterion": args.criterion,
        "k": args.k,
        "p": args.p,
        "spacing": args.spacing,
        "robot_radius": args.robot_radius,
        "clutter_size": args.clutter_size,
        "contrast": args.contrast,
    }
    return {**options, "method": args.method} if hasattr(args, "method") else options


def add_segmenter_options(parser: argparse.ArgumentParser, *, method: bool = True) -> None:
    """The options of :func:`segmenter_options`; ``method=False`` for the evaluations, which
    score both methods."""
    if method:
        parser.add_argument(
            "--method",
            default="spectral",
            choices=["spectral", "doors"],
            help="regions from the spectral partition (default) or the door-rule baseline",
        )
    parser.add_argument(
        "--criterion",
        choices=["auto", "nn", "hausdorff", "features", "view"],
        help="keyframe similarity: auto (default: view for 360 degree scans, as on a map "
        "alone, nn otherwise), view (the overlap of what two scans saw) or the paper's nn "
        "(eq. 12), hausdorff, features",
    )
    parser.add_argument(
        "--contrast",
        type=CONTRAST,
        default=2.0,
        help="how much a narrow passage weakens the affinity across it (0: similarity alone)",
    )
    parser.add_argument(
        "--k", type=int, help="guess of the number of regions (default: clearance basins)"
    )
    parser.add_argument("--p", type=float, default=0.3, help="sparsification parameter in [0, 1)")
    parser.add_argument(
        "--spacing", type=LENGTH, default=2.0, help="virtual keyframe lattice on a map, metres"
    )
    parser.add_argument(
        "--robot-radius",
        type=RADIUS,
        default=0.2,
        help="free space thinner than the robot is dropped, metres",
    )
    parser.add_argument(
        "--clutter-size",
        type=LENGTH,
        default=2.0,
        help="free-standing obstacles smaller than this are clutter, not walls, metres",
    )


def number_type(lo: float, hi: float, *, low_open: bool = False, unit: str = "m") -> Any:
    """An argparse type: a finite number in ``[lo, hi]`` (``(lo, hi]`` with ``low_open``),
    so a bad value is a usage error before any work."""

    def number(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
        problem = finite_in(value, "the value", lo, hi, unit=unit, low_open=low_open)
        if problem is not None:
            raise argparse.ArgumentTypeError(problem.replace("the value ", "", 1))
        return value

    return number


#: ``--robot-radius``, ``--resolution``, lengths and ranges in metres.
RADIUS = number_type(0.0, MAX_ROBOT_RADIUS, low_open=True)


RESOLUTION = number_type(*RESOLUTION_RANGE, unit="m per cell")


LENGTH = number_type(0.0, MAX_LENGTH, low_open=True)


DISTANCE = number_type(0.0, MAX_LENGTH)


#: How far apart a log's keyframes are taken by default, metres (``--distance``).
KEYFRAME_DISTANCE = 0.5


#: ``--stamp``: a time in seconds on a bag's clock, any finite number.
STAMP = number_type(-math.inf, math.inf, unit="s")


#: ``--theta``: a share in [0, 1].
SHARE = number_type(0.0, 1.0, unit="")


#: ``--contrast``: the openness exponent of the affinity, as ``PassageAffinity`` takes it.
CONTRAST = number_type(0.0, 63.0, unit="")


def count_type(lo: int, hi: int) -> Any:
    """An argparse type: a whole number in ``lo..hi``, so a count out of range (a negative
    one, or 10^10 queries that would run until killed) is a usage error before any work.

    Examples
    --------
    >>> count_type(1, 100)("30")
    30
    >>> count_type(1, 100)("-5")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: must be a whole number in 1..100, got '-5'
    """

    def count(text: str) -> int:
        if not (text.isdigit() and len(text) <= 12 and lo <= int(text) <= hi):
            raise argparse.ArgumentTypeError(f"must be a whole number in {lo}..{hi}, got {text!r}")
        return int(text)

    return count


#: The most workers, rounds or seeds a command takes: a thousand processes or runs is more
#: than a machine gives a batch, and a count of 10^8 would run until it is killed.
MAX_COUNT = 1000


def worker_count(text: str) -> int:
    """``--workers``, ``--rounds`` and ``--seeds``: a whole number in 1..:data:`MAX_COUNT`.

    Examples
    --------
    >>> worker_count("4")
    4
    >>> worker_count("100000")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: must be a whole number in 1..1000, got '100000'
    """
    if not (text.isdigit() and len(text) <= 6 and 1 <= int(text) <= MAX_COUNT):
        raise argparse.ArgumentTypeError(f"must be a whole number in 1..{MAX_COUNT}, got {text!r}")
    return int(text)


def whole_number(text: str) -> int:
    """``--seed`` (NumPy's seeds) and ``--max-paths``: a whole number of at least 0."""
    if not text.isdigit():
        raise argparse.ArgumentTypeError(f"must be a whole number >= 0, got {text!r}")
    return int(text)


def pose(text: str) -> tuple[float, ...]:
    """``"X,Y"`` or ``"X,Y,YAW"`` (metres, radians) as floats (an argparse type)."""
    try:
        values = tuple(float(p) for p in text.split(","))
    except ValueError:
        values = ()
    if len(values) not in (2, 3):
        raise argparse.ArgumentTypeError(
            f"expected X,Y in metres, got {text!r} (or X,Y,YAW, radians)"
        )
    return values


def point_or_region(text: str) -> tuple[float, ...] | int | str:
    """``--start`` and ``--goal``: ``X,Y`` (or ``X,Y,YAW``) is a point, a whole number a region
    id, anything else a name."""
    if "," in text:
        return pose(text)
    return int(text) if text.strip().isdigit() else text


ROBOT_HELP = (
    "robot model: disc:R, rect:LxW (turns in place), dubins:radius=R,footprint=LxW, "
    "reeds-shepp:radius=R,footprint=LxW (metres; a disc of --robot-radius by default)"
)


def add_robot_options(parser: argparse.ArgumentParser) -> None:
    """``--robot`` and, for footprint robots, ``--footprint L W`` and ``--turning-radius R``."""
    parser.add_argument("--robot", help=ROBOT_HELP)
    parser.add_argument(
        "--footprint",
        nargs=2,
        type=float,
        metavar=("L", "W"),
        help="with --robot rectangle, dubins or reeds-shepp: length and width, metres",
    )
    parser.add_argument(
        "--turning-radius", type=float, metavar="R", help="with --robot dubins or reeds-shepp"
    )


def robot_spec(args: argparse.Namespace) -> str | None:
    """The ``--robot`` spec, with ``--footprint`` and ``--turning-radius`` folded in.

    Examples
    --------
    >>> found = argparse.Namespace(robot="reeds-shepp", footprint=[0.9, 0.6], turning_radius=1.0)
    >>> robot_spec(found)
    'reeds-shepp:radius=1.0,footprint=0.9x0.6'
    >>> robot_spec(argparse.Namespace(robot="rect:0.9x0.6", footprint=None, turning_radius=None))
    'rect:0.9x0.6'
    """
    spec, footprint, radius = args.robot, args.footprint, args.turning_radius
    if footprint is None and radius is None:
        return spec
    kind = "" if spec is None else str(spec).strip().lower()
    if kind in ("rect", "rectangle"):
        if radius is not None:
            raise UsageError(
                "a rectangle turns in place: --turning-radius is for dubins or reeds-shepp"
            )
        if footprint is None:
            raise UsageError("--robot rectangle needs --footprint L W")
        return f"rect:{footprint[0]!r}x{footprint[1]!r}"
    if kind in ("dubins", "reeds-shepp", "reedsshepp"):
        if footprint is None or radius is None:
            raise UsageError(f"--robot {spec} needs --footprint L W and --turning-radius R")
        return f"{kind}:radius={radius!r},footprint={footprint[0]!r}x{footprint[1]!r}"
    raise UsageError(
        "--footprint and --turning-radius go with --robot rectangle, dubins or reeds-shepp "
        f"(a kind without ':'), got --robot {spec}"
    )


def load_map(args: argparse.Namespace) -> Any:
    """The :class:`TopoMap` of ``args.map``: the regions in ``args.regions`` (a folder
    written by ``topomap segment``) or a segmentation made now."""
    from maps.grid import OccupancyGrid
    from topomap.topomap import TopoMap

    if args.regions is not None:
        topo = TopoMap.load(args.regions)
        if Path(args.map).resolve() == (Path(args.regions) / "map.yaml").resolve():
            return topo  # the folder's own map: read once
        if topo.grid != OccupancyGrid.load(args.map):
            raise UsageError(f"{args.regions} holds the regions of another map than {args.map}")
        return topo
    args.progress.stage(f"segmenting {args.map}")
    return TopoMap.from_grid(OccupancyGrid.load(args.map))


def map_inputs(args: argparse.Namespace) -> list[Path | str | None]:
    """The inputs :func:`load_map` reads: the map YAML, the image it names and the regions
    folder (None when not given)."""
    from maps.map_server import map_files

    return [*map_files(args.map), args.regions]


def refuse_inputs_as_outputs(
    outputs: Iterable[str | None], inputs: Iterable[str | Path | None]
) -> None:
    """Refuse an output that would replace an input, even with ``--force``: an output that
    is an input file or a file inside an input folder, or an output folder that is or holds
    an input (a folder written whole would take its files).

    Examples
    --------
    >>> import tempfile
    >>> seg = Path(tempfile.mkdtemp()); _ = (seg / "graph.json").write_text("{}")
    >>> refuse_inputs_as_outputs([str(seg / "route.geojson")], [str(seg)])  # a new file
    >>> refuse_inputs_as_outputs([str(seg / "graph.json")], [str(seg)])
    Traceback (most recent call last):
    ...
    topomap.errors.UsageError: ...graph.json would be written over the input ...: choose ...
    """
    sources = [Path(path).resolve() for path in inputs if path is not None]
    for output in outputs:
        if output is None:
            continue
        target = Path(output).resolve()
        for source in sources:
            inside = source.is_dir() and source in target.parents and target.exists()
            holds = target == source or target in source.parents
            if inside or holds:
                raise UsageError(
                    f"{output} would be written over the input {source}: choose another output"
                )
