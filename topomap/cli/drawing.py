"""Pictures of maps, routes and keyframes, written to PNG files.

The regions picture of ``topomap segment`` is drawn with OpenCV on the map's own cells (a
fraction of a second on the largest maps). Figures with axes and legends are made with
matplotlib's object API (:class:`matplotlib.figure.Figure`, which writes PNGs with the Agg
canvas), never through pyplot: no global backend is chosen, no window opens and nothing is
left for the caller to close.
"""

from __future__ import annotations

import errno
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from maps.errors import OutputWriteError
from maps.files import written
from maps.grid import OccupancyGrid

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


def map_image(
    grid: OccupancyGrid,
    labels: NDArray[np.integer] | None = None,
    alpha: float = 0.8,
    colours: NDArray[np.float64] | None = None,
) -> NDArray[np.uint8]:
    """``grid`` as an RGBA image of its cells (row 0 at the top): free white, occupied black,
    unknown grey, and the regions of ``labels`` over it in colour (opacity ``alpha``; RGBA
    ``colours`` per region id, :func:`region_colours` by default), looked up in a table of
    every (cell class, region) colour."""
    kind = grid.free.astype(np.int32)  # 0 unknown, 1 free, 2 occupied (32 bits: faster)
    kind[grid.occupied] = 2
    shades = np.array([0.75, 1.0, 0.0])[:, None, None]
    if labels is None:
        labels = np.zeros(grid.shape, np.int32)
    if colours is None:
        colours = region_colours(int(labels.max(initial=0)))
    weight = alpha * colours[None, :, 3:]
    table = shades * (1 - weight) + colours[None, :, :3] * weight  # (class, region, rgb)
    table = np.concatenate((table, np.ones((*table.shape[:2], 1))), axis=2)
    rgba = np.rint(255 * table).astype(np.uint8).reshape(-1, 4)
    return np.take(rgba, kind * len(colours) + labels, axis=0)  # faster than table[kind, labels]


def show_grid(
    ax: Axes, grid: OccupancyGrid, labels: NDArray[np.integer] | None = None, alpha: float = 0.8
) -> None:
    """Draw :func:`map_image` on ``ax`` in map-frame metres."""
    image = map_image(grid, labels, alpha)
    xmin, ymin, xmax, ymax = grid.bounds()
    ax.imshow(image, extent=(xmin, xmax, ymin, ymax), interpolation="nearest")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")


def _map_figure(
    grid: OccupancyGrid, labels: NDArray[np.integer] | None = None, alpha: float = 0.8
) -> tuple[Figure, Axes]:
    """``(figure, axes)``: the map 12 inches wide, with the regions in colour if given."""
    from matplotlib.figure import Figure

    xmin, ymin, xmax, ymax = grid.bounds()
    width = 12.0
    fig = Figure(figsize=(width, max(3.0, width * (ymax - ymin) / (xmax - xmin))))
    ax = fig.subplots()
    show_grid(ax, grid, labels, alpha)
    return fig, ax


def _save(fig: Figure, ax: Axes, path: str | Path, title: str) -> Path:
    """Title the axes, write the figure as a PNG."""
    ax.set_title(title)
    path = Path(path)
    with written(path, overwrite=True) as partial:  # callers refuse existing files first
        fig.savefig(partial, dpi=150, bbox_inches="tight")
    return path


def draw_map(
    path: str | Path,
    grid: OccupancyGrid,
    *,
    route: NDArray[np.float64] | None = None,
    keyframes: NDArray[np.float64] | None = None,
    title: str = "",
) -> Path:
    """Write a PNG of ``grid`` with an optional route ``(n, 2+)`` and keyframe poses ``(k, 3)``."""
    fig, ax = _map_figure(grid)
    if route is not None:
        ax.plot(route[:, 0], route[:, 1], color="tab:blue", lw=0.6, alpha=0.7, label="route")
    if keyframes is not None:
        ax.quiver(
            keyframes[:, 0],
            keyframes[:, 1],
            np.cos(keyframes[:, 2]),
            np.sin(keyframes[:, 2]),
            color="tab:red",
            scale=150,
            width=0.001,
            label=f"{len(keyframes)} keyframes",
        )
    if route is not None or keyframes is not None:
        ax.legend(loc="upper right", fontsize=8)
    return _save(fig, ax, path, title)


def region_colours(count: int, seed: int = 7) -> NDArray[np.float64]:
    """``(count + 1, 4)`` RGBA colours: index 0 transparent, the rest distinct pastel."""
    rng = np.random.default_rng(seed)
    colours = np.ones((count + 1, 4))
    colours[1:, :3] = 0.35 + 0.6 * rng.random((count, 3))
    colours[0] = 0.0
    return colours


#: The unknown space shown round a map's known part in :func:`draw_regions`, metres.
FRAME = 1.0


def draw_regions(
    path: str | Path, grid: OccupancyGrid, labels: NDArray[np.integer], graph: Any, title: str = ""
) -> Path:
    """Write a PNG of the regions in colour with the region graph drawn over them (OpenCV).

    The picture shows the map's known part and :data:`FRAME` metres round it (a SLAM
    package's canvas is mostly unknown), scaled so that its longer side has at least 1,600
    pixels. Each door is a red
    segment; the graph's edges are drawn door to door inside each region
    (:func:`topomap.graph_layout.edge_segments`: a hall with many doors is a tree along them,
    not a star over its name); each region's name (or id) is written once at its most open
    point, in letters sized to the picture (about 1/110 of its longer side, never under 10
    pixels). ``title`` is written on a band above the map.
    """
    import cv2

    from topomap.graph_layout import edge_segments

    rows, cols = grid.known_box(FRAME)
    grid, labels = grid.cropped(rows, cols), labels[rows, cols]
    scale = max(1, int(np.ceil(1600 / max(grid.shape))))
    image = cv2.cvtColor(map_image(grid, labels), cv2.COLOR_RGBA2BGR)
    image = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)

    def pixel(points: Any) -> NDArray[np.int32]:
        xy = np.asarray(points, float).reshape(-1, 2)
        rows, cols = grid.world_to_cell(xy[:, 0], xy[:, 1])
        return (np.column_stack([cols, rows]) * scale + scale // 2).astype(np.int32)

    font = cv2.FONT_HERSHEY_SIMPLEX
    size = max(max(image.shape[:2]) / 110, 10) / 22  # cv2's letters are 22 px at size 1
    thick = max(1, round(2 * size))
    for _, _, doors in graph.edges(data="doors"):
        for door in doors or ():
            ends = pixel([door.start, door.end])
            cv2.line(image, tuple(ends[0]), tuple(ends[1]), (40, 40, 220), 2 * thick, cv2.LINE_AA)
    for _, (start, end) in edge_segments(graph):
        line = pixel([start, end])
        cv2.line(image, tuple(line[0]), tuple(line[1]), (0, 0, 0), thick, cv2.LINE_AA)
    for node, data in graph.nodes(data=True):
        (x, y) = pixel([[data["x"], data["y"]]])[0]
        cv2.circle(image, (int(x), int(y)), 2 * thick, (0, 0, 0), -1, cv2.LINE_AA)
        text = str(data.get("name", node))
        (w, _), _ = cv2.getTextSize(text, font, size, thick)
        at = (int(x) - w // 2, int(y) - 3 * thick)
        cv2.putText(image, text, at, font, size, (255, 255, 255), 3 * thick, cv2.LINE_AA)
        cv2.putText(image, text, at, font, size, (0, 0, 0), thick, cv2.LINE_AA)
    if title:  # on a band of its own above the map
        band = np.full((round(40 * size) + 12, image.shape[1], 3), 255, np.uint8)
        at = (8, round(30 * size) + 4)
        cv2.putText(band, title, at, font, 1.2 * size, (0, 0, 0), thick, cv2.LINE_AA)
        image = np.vstack([band, image])
    return write_png(path, image)


def write_png(path: str | Path, image: NDArray[Any]) -> Path:
    """Write a BGR ``image`` as a PNG under a temporary name, renamed into place (callers
    refuse existing files first).

    The rows are stored unfiltered and deflated with zlib's default strategy (OpenCV's
    default is the Sub filter with run-length matches): pictures of maps are runs of flat
    colour that zlib finds as they are, and the filter costs more than it saves (the ipa
    plans' pictures a fifth faster to encode and a quarter smaller, the same pixels).
    """
    import cv2

    path = Path(path)
    options = [
        cv2.IMWRITE_PNG_FILTER,
        cv2.IMWRITE_PNG_FILTER_NONE,
        cv2.IMWRITE_PNG_STRATEGY,
        cv2.IMWRITE_PNG_STRATEGY_DEFAULT,
    ]
    ok, encoded = cv2.imencode(".png", image, options)
    if not ok:
        raise OutputWriteError(path, OSError(errno.EIO, "the PNG encoder failed"))
    with written(path, overwrite=True) as partial:
        partial.write_bytes(encoded.tobytes())
    return path


def draw_paths(
    path: str | Path,
    grid: OccupancyGrid,
    labels: NDArray[np.integer],
    paths: dict[str, Any],
    title: str = "",
) -> Path:
    """Write a PNG of planned paths (``label -> Path``) over the regions, with their lengths
    and query times in the legend."""
    fig, ax = _map_figure(grid, labels, alpha=0.4)
    for k, (label, planned) in enumerate(paths.items()):
        points = planned.waypoints
        text = f"{label}: {planned.length:.1f} m, {1000 * planned.total_seconds:.1f} ms"
        ax.plot(points[:, 0], points[:, 1], "-", color=f"C{k}", lw=2, label=text)
    first = next(iter(paths.values())).waypoints
    ax.plot(*first[0], "o", color="green", ms=8)
    ax.plot(*first[-1], "*", color="red", ms=12)
    ax.legend(loc="upper right", fontsize=8)
    return _save(fig, ax, path, title)
