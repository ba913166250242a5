"""Pictures of maps, routes and keyframes, written to files (matplotlib, Agg backend)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from maps.grid import OccupancyGrid

if TYPE_CHECKING:
    from matplotlib.axes import Axes


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def show_grid(ax: Axes, grid: OccupancyGrid) -> None:
    """Draw ``grid`` in map-frame metres: free white, occupied black, unknown grey."""
    shade = np.full(grid.shape, 0.75)
    shade[grid.free] = 1.0
    shade[grid.occupied] = 0.0
    xmin, ymin, xmax, ymax = grid.bounds()
    ax.imshow(
        shade, cmap="gray", vmin=0, vmax=1, extent=(xmin, xmax, ymin, ymax), interpolation="nearest"
    )
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")


def draw_map(
    path: str | Path,
    grid: OccupancyGrid,
    *,
    route: NDArray[np.float64] | None = None,
    keyframes: NDArray[np.float64] | None = None,
    title: str = "",
) -> Path:
    """Write a PNG of ``grid`` with an optional route ``(n, 2+)`` and keyframe poses ``(k, 3)``."""
    plt = _pyplot()
    xmin, ymin, xmax, ymax = grid.bounds()
    width = 12.0
    fig, ax = plt.subplots(figsize=(width, max(3.0, width * (ymax - ymin) / (xmax - xmin))))
    show_grid(ax, grid)
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
    ax.set_title(title)
    path = Path(path)
    fig.savefig(path, dpi=150, bbox_inches="tight")
    plt.close(fig)
    return path
