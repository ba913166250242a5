"""Plane geometry shared by every package (metres, map frame)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def polyline_length(points: ArrayLike) -> float:
    """Length of the polyline through ``points`` (``(n, 2)``, or poses ``(n, 3)``: the
    heading is ignored), metres.

    Examples
    --------
    >>> polyline_length([[0.0, 0.0], [3.0, 4.0], [3.0, 5.0]])
    6.0
    """
    p = np.asarray(points, float)
    p = p.reshape(-1, 2) if p.ndim == 1 else p[:, :2]
    return float(np.hypot(*np.diff(p, axis=0).T).sum())
