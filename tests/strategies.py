"""Hypothesis draws shared by the tests."""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st
from numpy.typing import NDArray


def map_cells(data: st.DataObject, height: int, width: int) -> NDArray[np.int8]:
    """A ``height`` x ``width`` map's cells, each unknown, free or occupied, drawn from
    ``data``."""
    size = height * width
    values = data.draw(st.lists(st.sampled_from([-1, 0, 100]), min_size=size, max_size=size))
    return np.array(values, np.int8).reshape(height, width)
