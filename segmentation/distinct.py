"""The distinct values of an integer array, sorted, as :func:`numpy.unique` gives them, at the
cost of one sort.

NumPy 2.4's ``np.unique`` without ``return_*`` finds the values by hashing, then sorts them: on
arrays of mostly distinct integers (cell keys of a scan, the cells of a ring grown over a map)
it is 4-11 times slower than sorting and comparing neighbours (measured on this project's
machine: 1,000 values 0.10 against 0.02 ms, 100,000 18 against 4 ms, 1,000,000 591 against
53 ms). The hot paths that want the distinct keys use :func:`distinct`.
"""

from __future__ import annotations

from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

Integer = TypeVar("Integer", bound=np.integer)


def distinct(values: NDArray[Integer]) -> NDArray[Integer]:
    """The distinct values of ``values`` (any shape, flattened), ascending: ``np.unique(values)``.

    Examples
    --------
    >>> distinct(np.array([5, 3, 5, -1, 3])).tolist()
    [-1, 3, 5]
    >>> distinct(np.zeros((0, 2), np.int64)).shape
    (0,)
    """
    ordered = np.sort(values, axis=None)
    if len(ordered) == 0:
        return ordered
    return ordered[np.r_[True, ordered[1:] != ordered[:-1]]]
