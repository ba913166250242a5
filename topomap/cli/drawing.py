"""Pictures of maps, routes and keyframes, written to PNG files.

Figures are made with matplotlib's object API (:class:`matplotlib.figure.Figure`, which writes
PNGs with the Agg canvas), never through pyplot: no global backend is chosen, no window opens
and nothing is left for the caller to close.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from maps.files import written
from maps.grid import OccupancyGrid

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


def show_grid(
    ax: Axes, grid: OccupancyGrid, labels: NDArray[np.integer] | None = None, alpha: float = 0.8
) -> None:
    """Draw ``grid`` in map-frame metres: free white, occupied black, unknown grey, and the
    regions of ``labels`` over it in colour (opacity ``alpha``), as one RGBA image of bytes
    looked up in a table of every (cell class, region) colour."""
    kind = np.zeros(grid.shape, np.intp)  # 0 unknown, 1 free, 2 occupied
    kind[grid.free] = 1
    kind[grid.occupied] = 2
    shades = np.array([0.75, 1.0, 0.0])[:, None, None]
    if labels is None:
        labels = np.zeros(grid.shape, np.intp)
    colours = region_colours(int(labels.max(initial=0)))
    weight = alpha * colours[None, :, 3:]
    table = shades * (1 - weight) + colours[None, :, :3] * weight  # (class, region, rgb)
    table = np.concatenate((table, np.ones((*table.shape[:2], 1))), axis=2)
    image = np.rint(255 * table).astype(np.uint8)[kind, labels]
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


def draw_regions(
    path: str | Path, grid: OccupancyGrid, labels: NDArray[np.integer], graph: Any, title: str = ""
) -> Path:
    """Write a PNG of the regions in colour with the region graph drawn over them.

    Nodes are drawn at each region's inside point with its id (and name, if it has one);
    edges run from node to node through the centres of their widest door, drawn as a segment.
    """
    fig, ax = _map_figure(grid, labels, alpha=0.8)
    for a, b, data in graph.edges(data=True):
        door = data["doors"][0]
        ends = np.array([door.start, door.end])
        ax.plot(ends[:, 0], ends[:, 1], color="tab:red", lw=2.5)
        line = np.array([[graph.nodes[a]["x"], graph.nodes[a]["y"]], door.centre])
        line = np.vstack([line, [[graph.nodes[b]["x"], graph.nodes[b]["y"]]]])
        ax.plot(line[:, 0], line[:, 1], color="black", lw=0.8)
    for node, data in graph.nodes(data=True):
        ax.plot(data["x"], data["y"], "o", color="black", ms=3)
        ax.annotate(
            str(data.get("name", node)),
            (data["x"], data["y"]),
            fontsize=6,
            ha="center",
            va="bottom",
            xytext=(0, 2),
            textcoords="offset points",
        )
    return _save(fig, ax, path, title)


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
