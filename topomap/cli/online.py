"""Online segmentation for the command line, the demo and the benchmark.

A run's keyframes go through an online segmenter one at a time after a seed on the first ones:
:class:`~segmentation.incremental.IncrementalSegmenter` (``"windows"``, the offline engine
re-partitioning the robot's neighbourhood; default) or the paper's Section IV rules
:class:`~segmentation.online.OnlineSegmenter` (``"centres"``, the baseline); pictures of the
growing regions are written every few keyframes and gathered into an animated GIF; the final
partition is made dense on the map of the whole run, exactly as the offline keyframes are, so
both can be scored alike.
"""

from __future__ import annotations

import csv
import json
import logging
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import networkx as nx
import numpy as np
from numpy.typing import NDArray

from maps.errors import MapTooLargeError, OutputExistsError
from maps.files import OutputFolder, write_text
from maps.grid import OccupancyGrid
from maps.mapping import check_map_extent, grid_from_keyframes
from maps.scan import Keyframe, poses_array, seeing
from segmentation.errors import SegmentationError
from segmentation.events import Event
from segmentation.graph import region_graph
from segmentation.incremental import IncrementalSegmenter
from segmentation.metrics import adjusted_rand
from segmentation.online import OnlineSegmenter
from segmentation.refine import basins, count_basins
from segmentation.regions import Regions, dense_labels
from segmentation.spectral import SpectralSegmenter
from topomap.cli.commands.common import ONLINE_METHODS
from topomap.cli.drawing import region_colours, write_png
from topomap.errors import UsageError
from topomap.labels import label_graph
from topomap.saving import SAVED

log = logging.getLogger(__name__)

#: A seed is this share of the keyframes ...
SEED_SHARE = 0.1
#: ... and at least this many (fewer cannot hold two rooms' worth of keyframes).
MIN_SEED = 40
#: Cell size of the map of a run, metres (the offline command's).
RESOLUTION = 0.05


def default_seed(count: int) -> int:
    """The seed size for a run of ``count`` keyframes: :data:`SEED_SHARE` of them, at least
    :data:`MIN_SEED`; a warning when the run is too short to seed and go on online.

    Examples
    --------
    >>> default_seed(1000), default_seed(100)
    (100, 40)
    """
    seed = min(count, max(MIN_SEED, round(SEED_SHARE * count)))
    if count < 2 * MIN_SEED:
        log.warning(
            "%d keyframes: too few to seed (%d) and go on online; the seed is %d of them",
            count,
            MIN_SEED,
            seed,
        )
    return seed


def offline_segmenter(
    keyframes: Sequence[Keyframe],
    random_state: int = 0,
    grid: OccupancyGrid | None = None,
    **options: Any,
) -> SpectralSegmenter:
    """A :class:`SpectralSegmenter` with ``options``; without ``k``, the guess ``k'`` as
    :class:`~topomap.topomap.TopoMap` makes it: the clearance basins of ``grid`` (by default
    the map built from ``keyframes``), at most one per keyframe."""
    if options.get("k") is None:
        grid = grid_from_keyframes(keyframes, RESOLUTION) if grid is None else grid
        options["k"] = min(len(keyframes), count_basins(grid, basins(grid)))
    return SpectralSegmenter(random_state=random_state, **options)


def latency_ms(seconds: Sequence[float], prefix: str = "") -> dict[str, float]:
    """``{prefix}median_ms``, ``{prefix}p95_ms`` and ``{prefix}max_ms`` of times in seconds.

    Examples
    --------
    >>> latency_ms([0.001, 0.002, 0.010], "cpu_")
    {'cpu_median_ms': 2.0, 'cpu_p95_ms': 9.2, 'cpu_max_ms': 10.0}
    """
    ms = 1000 * np.asarray(seconds)
    return {
        f"{prefix}median_ms": round(float(np.median(ms)), 3),
        f"{prefix}p95_ms": round(float(np.percentile(ms, 95)), 3),
        f"{prefix}max_ms": round(float(ms.max()), 3),
    }


@dataclass
class OnlineRun:
    """An online pass over a run: the segmenter, the time of every ``partial_fit`` after the
    seed and of the final :meth:`~segmentation.events.OnlineEstimator.flush` (seconds) and
    the pictures written."""

    online: IncrementalSegmenter | OnlineSegmenter
    seed_seconds: float
    seconds: list[float] = field(default_factory=list)
    flush_seconds: float = 0.0
    frames: list[Path] = field(default_factory=list)

    def latency_ms(self) -> dict[str, float]:
        """Median, 95th percentile and maximum time per keyframe, milliseconds."""
        return latency_ms(self.seconds or [0.0])


def run_online(
    keyframes: Sequence[Keyframe],
    *,
    seed_keyframes: int | None = None,
    method: str = "windows",
    theta: float = 0.5,
    random_state: int = 0,
    frames_every: int | None = None,
    frames_dir: Path | None = None,
    progress: Callable[[Iterable[Any]], Iterable[Any]] = iter,
    **options: Any,
) -> OnlineRun:
    """Seed on the first ``seed_keyframes`` (:func:`default_seed` by default), then assign the
    others one by one with ``method`` (:data:`ONLINE_METHODS`), timing each; every
    ``frames_every`` keyframes draw the regions so far into ``frames_dir``. ``options`` are
    segmentation options (``criterion``, ``k``, ``p``; for ``"centres"``, ``k'`` comes from the
    seed's map unless ``k`` is given)."""
    if method not in ONLINE_METHODS:
        raise UsageError(
            f"--online-method must be one of {', '.join(ONLINE_METHODS)}, got {method!r}"
        )
    if len(keyframes) < 2:
        raise UsageError(f"an online run needs at least 2 keyframes, got {len(keyframes)}")
    if seed_keyframes is None:
        seed_keyframes = default_seed(len(keyframes))
    if not 2 <= seed_keyframes <= len(keyframes):
        raise UsageError(
            f"--seed-keyframes must lie in 2..{len(keyframes)} (the keyframes), "
            f"got {seed_keyframes}"
        )
    if frames_every is not None and frames_every < 1:
        raise UsageError(f"--frames must be a number of keyframes >= 1, got {frames_every}")
    options = {name: value for name, value in options.items() if value is not None}
    k = options.get("k")
    if k is not None and not 1 <= k <= len(keyframes):
        raise UsageError(f"--k must lie in 1..{len(keyframes)} (the keyframes), got {k}")
    seed = keyframes[:seed_keyframes]
    start = time.perf_counter()
    online: IncrementalSegmenter | OnlineSegmenter
    if method == "windows":
        from topomap.topomap import pipeline_from_options

        pipeline = pipeline_from_options(options)
        online = IncrementalSegmenter(pipeline, random_state=random_state)
    else:
        online = OnlineSegmenter(offline_segmenter(seed, random_state, **options), theta=theta)
    online.fit(seed)
    run = OnlineRun(online, time.perf_counter() - start)
    if frames_every is not None and frames_dir is not None:
        frames_dir.mkdir(parents=True, exist_ok=True)
        run.frames.append(draw_online(frames_dir / f"frame_{seed_keyframes:06d}.png", online))
    for index in progress(range(seed_keyframes, len(keyframes))):
        start = time.perf_counter()
        online.partial_fit(keyframes[index])
        run.seconds.append(time.perf_counter() - start)
        done = index + 1
        if frames_every and frames_dir is not None and (done - seed_keyframes) % frames_every == 0:
            run.frames.append(draw_online(frames_dir / f"frame_{done:06d}.png", online))
    start = time.perf_counter()
    online.flush()  # the last re-partition, under way beside the last arrivals
    run.flush_seconds = time.perf_counter() - start
    return run


def dense_regions(
    grid: OccupancyGrid,
    keyframes: Sequence[Keyframe],
    labels: NDArray[np.integer],
    *,
    named: bool = True,
) -> tuple[Regions, nx.Graph, NDArray[np.int64]]:
    """Keyframe labels made dense on ``grid`` as the offline pipeline does (each free cell
    takes the label of its geodesically nearest keyframe), the region graph (with place
    labels and names when ``named``), and the region of each keyframe's cell."""
    poses = poses_array(keyframes)
    rows, cols = grid.world_to_cell(poses[:, 0], poses[:, 1])
    regions = Regions(grid, dense_labels(grid, rows, cols, np.asarray(labels, np.int64)))
    inside = grid.contains(rows, cols)
    keyframe_regions = np.zeros(len(keyframes), np.int64)
    keyframe_regions[inside] = regions.labels[rows[inside], cols[inside]]
    graph = region_graph(regions, keyframe_regions)
    if not named:
        return regions, graph, keyframe_regions
    label_graph(regions, graph)
    return regions, graph, keyframe_regions


def agreement(online: NDArray[np.integer], offline: NDArray[np.integer]) -> float:
    """Adjusted Rand index of two keyframe partitions (from their contingency table, without
    importing scikit-learn).

    Examples
    --------
    >>> agreement(np.array([1, 1, 2, 2]), np.array([5, 5, 7, 7]))
    1.0
    """
    pairs, counts = np.unique(np.column_stack([online, offline]), axis=0, return_counts=True)
    rows = np.unique(pairs[:, 0], return_inverse=True)[1]
    cols = np.unique(pairs[:, 1], return_inverse=True)[1]
    table = np.zeros((rows.max() + 1, cols.max() + 1))
    table[rows, cols] = counts
    return round(adjusted_rand(table), 4)


def draw_online(
    path: Path, online: IncrementalSegmenter | OnlineSegmenter, title: str | None = None
) -> Path:
    """A picture of the online dense regions and the region graph so far: 1,000 x 750
    pixels whatever the map (so the pictures can be frames of one GIF), the claimed area
    scaled to fit, region ids in bold letters on a white halo (drawn with OpenCV)."""
    import cv2

    width, height, band = 1000, 750, 36
    regions = online.regions_
    assert regions is not None  # both engines keep dense regions by default
    labels, (xmin, _, _, ymax) = regions.label_image()
    canvas = np.full((height, width, 3), 217, np.uint8)
    rows, cols = np.nonzero(labels)
    if len(rows):  # the claimed area, not the arrays' spare border
        top, left = max(rows.min() - 5, 0), max(cols.min() - 5, 0)
        crop = labels[top : rows.max() + 6, left : cols.max() + 6]
        scale = min((width - 20) / crop.shape[1], (height - band - 20) / crop.shape[0])
        size = (max(1, round(crop.shape[1] * scale)), max(1, round(crop.shape[0] * scale)))
        colours = np.round(255 * region_colours(int(labels.max(initial=0)))[:, :3]).astype(np.uint8)
        colours[0] = 217  # not claimed: the background's grey
        picture = cv2.resize(colours[crop][..., ::-1], size, interpolation=cv2.INTER_NEAREST)
        y0, x0 = band + (height - band - size[1]) // 2, (width - size[0]) // 2
        canvas[y0 : y0 + size[1], x0 : x0 + size[0]] = picture
        cell = regions.resolution

        def pixel(x: float, y: float) -> tuple[int, int]:
            return (
                round(x0 + ((x - xmin) / cell - left) * scale),
                round(y0 + ((ymax - y) / cell - top) * scale),
            )

        graph = online.graph_
        for a, b in graph.edges:
            start = pixel(graph.nodes[a]["x"], graph.nodes[a]["y"])
            end = pixel(graph.nodes[b]["x"], graph.nodes[b]["y"])
            cv2.line(canvas, start, end, (90, 90, 90), 1, cv2.LINE_AA)
        font = cv2.FONT_HERSHEY_SIMPLEX
        for node, data in graph.nodes(data=True):
            text = str(node)
            (w, h), _ = cv2.getTextSize(text, font, 0.5, 2)
            x, y = pixel(data["x"], data["y"])
            at = (x - w // 2, y + h // 2)
            cv2.putText(canvas, text, at, font, 0.5, (255, 255, 255), 4, cv2.LINE_AA)
            cv2.putText(canvas, text, at, font, 0.5, (0, 0, 0), 2, cv2.LINE_AA)
    caption = title or f"keyframe {len(online.labels_)}: {online.n_regions_} regions"
    canvas[:band] = 255
    cv2.putText(canvas, caption, (12, 25), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (0, 0, 0), 2, cv2.LINE_AA)
    return write_png(path, canvas)


def write_gif(frames: Sequence[Path], path: Path, seconds_per_frame: float = 0.4) -> Path:
    """An animated GIF (looping) of the PNG ``frames``."""
    from PIL import Image

    images = [Image.open(frame).convert("RGB") for frame in frames]
    images[0].save(
        path,
        save_all=True,
        append_images=images[1:],
        duration=round(1000 * seconds_per_frame),
        loop=0,
    )
    return path


def write_events(path: Path, events: Iterable[Event]) -> Path:
    """``events.jsonl``: one JSON object per event."""
    with path.open("w") as stream:
        for event in events:
            stream.write(json.dumps(event.as_dict()) + "\n")
    return path


def write_keyframes(
    path: Path,
    keyframes: Sequence[Keyframe],
    regions: NDArray[np.integer],
    online: IncrementalSegmenter | OnlineSegmenter,
) -> Path:
    """``keyframes.csv``: ``scan_index,x,y,theta,region`` as offline (``region`` = the dense
    region of ``regions.png`` at the keyframe) plus ``region_on_arrival`` and
    ``region_final`` (the online ids, stable over the run)."""
    rows = zip(keyframes, regions, online.arrival_labels_, online.labels_, strict=True)
    with path.open("w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(
            ["scan_index", "x", "y", "theta", "region", "region_on_arrival", "region_final"]
        )
        for frame, region, arrival, final in rows:
            pose = (f"{v:.4f}" for v in frame.pose)
            writer.writerow([frame.scan_index, *pose, int(region), int(arrival), int(final)])
    return path


def online_outputs(*, picture: bool = True, frames: bool = False) -> list[str]:
    """The files :func:`segment_online` writes (``frames/``, a folder, aside).

    Examples
    --------
    >>> online_outputs(picture=False)  # doctest: +NORMALIZE_WHITESPACE
    ['regions.png', 'regions_colour.png', 'graph.graphml', 'graph.json', 'regions.geojson',
     'topomap.json', 'map.yaml', 'map.pgm', 'keyframes.csv', 'events.jsonl', 'summary.json']
    """
    names = [*SAVED, "map.yaml", "map.pgm", "keyframes.csv", "events.jsonl"]
    names += ["segmentation.png"] if picture else []
    names += ["regions.gif"] if frames else []
    return [*names, "summary.json"]


def segment_online(
    keyframes: Sequence[Keyframe],
    out: Path,
    *,
    source: str,
    seed_keyframes: int | None = None,
    method: str = "windows",
    theta: float = 0.5,
    frames_every: int | None = None,
    overwrite: bool = False,
    picture: bool = True,
    progress: Callable[[Iterable[Any]], Iterable[Any]] = iter,
    **options: Any,
) -> dict[str, Any]:
    """``topomap segment --scans LOG --online``: the online pass, then the files of the
    offline command for its final partition (the folder of :meth:`TopoMap.save`, which
    ``view``, ``plan``, ``export`` and :meth:`TopoMap.load` read; ``keyframes.csv``,
    ``segmentation.png`` unless not ``picture``, ``summary.json``), plus ``events.jsonl`` and, with
    ``frames_every``, ``frames/*.png`` and ``regions.gif``. Returns the summary. Keyframes with
    no valid beam are left out, as offline (:func:`~maps.scan.seeing`), and counted in the
    summary.

    Every output is checked before any work (:func:`online_outputs`; ``overwrite`` to replace
    them) and all appear at once, written through :class:`~maps.files.OutputFolder`: a failed
    or interrupted run leaves ``out`` as it was.

    Raises
    ------
    OutputExistsError
        An output exists and not ``overwrite``.
    MapTooLargeError
        The keyframes spread farther than memory allows (checked before the online pass, as
        offline before the map is built); naming ``source``.
    SegmentationError
        No region was found (the keyframes saw no free space).
    """
    from topomap.cli.drawing import draw_regions
    from topomap.topomap import TopoMap

    names = online_outputs(picture=picture, frames=bool(frames_every))
    if frames_every and not overwrite and (out / "frames").exists():
        raise OutputExistsError(out / "frames", "--force")
    folder = OutputFolder(out, names, overwrite=overwrite, how="--force", last="summary.json")
    seen = seeing(keyframes)
    with folder as work:
        try:
            check_map_extent(keyframes, RESOLUTION)  # the run's map, refused before any fit
            run = run_online(
                seen,
                seed_keyframes=seed_keyframes,
                method=method,
                theta=theta,
                frames_every=frames_every,
                frames_dir=work / "frames" if frames_every else None,
                progress=progress,
                **options,
            )
            start = time.perf_counter()
            grid = grid_from_keyframes(keyframes, RESOLUTION)
        except MapTooLargeError as err:
            raise MapTooLargeError(str(err), path=source) from None
        online = run.online
        regions, graph, keyframe_regions = dense_regions(grid, seen, online.labels_)
        dense_seconds = time.perf_counter() - start
        if graph.number_of_nodes() == 0:  # as the offline command refuses a map without space
            raise SegmentationError(
                f"{source}: no region: the {len(seen)} keyframes saw no free space a "
                f"robot fits in ({int(grid.free.sum())} free cells on the map)"
            )
        topo = TopoMap(
            grid, regions, graph, seconds={"dense": dense_seconds}, next_id=max(regions.ids) + 1
        )
        written = [
            *topo.save(work),
            write_keyframes(work / "keyframes.csv", seen, keyframe_regions, online),
            write_events(work / "events.jsonl", online.events_),
        ]
        if picture:
            title = f"{Path(source).name} online: {graph.number_of_nodes()} regions"
            written.append(
                draw_regions(work / "segmentation.png", grid, regions.labels, graph, title=title)
            )
        if run.frames:
            written.append(write_gif(run.frames, work / "regions.gif"))
        skipped = len(keyframes) - len(seen)
        summary = _online_summary(run, seen, skipped, graph, source, method, theta, dense_seconds)
        summary["written"] = [p.name for p in written]
        write_text(work / "summary.json", json.dumps(summary, indent=2))
    return summary


def _online_summary(
    run: OnlineRun,
    keyframes: Sequence[Keyframe],
    skipped: int,
    graph: nx.Graph,
    source: str,
    method: str,
    theta: float,
    dense_seconds: float,
) -> dict[str, Any]:
    """The summary of :func:`segment_online` (but the files written) of a run of
    ``keyframes``, ``skipped`` more having no valid beam."""
    online = run.online
    kinds = [e.kind for e in online.events_ if e.keyframe >= online.n_seed_]
    return {
        "source": source,
        "keyframes": len(keyframes),
        "keyframes_without_valid_beam": skipped,
        "method": method,
        "seed_keyframes": online.n_seed_,
        **(
            {"theta": theta, "threshold_T": round(online.threshold_, 4)}
            if isinstance(online, OnlineSegmenter)
            else {}
        ),
        "online_regions": online.n_regions_,
        "regions": graph.number_of_nodes(),
        "events_after_seed": {
            kind: kinds.count(kind) for kind in ("created", "grown", "merged", "split")
        },
        "latency": run.latency_ms(),
        "seconds": {
            "seed": round(run.seed_seconds, 3),
            "online_total": round(sum(run.seconds), 3),
            "final_dense_regions": round(dense_seconds, 3),
        },
        "names": {int(r): name for r, name in sorted(graph.nodes(data="name"))},
        "frames": len(run.frames),
    }
