"""Random state handling: every stochastic function takes an int seed or a numpy Generator."""

from __future__ import annotations

import numpy as np

from maps.errors import RandomStateError

RandomState = int | np.random.Generator | None


def as_generator(random_state: RandomState) -> np.random.Generator:
    """A numpy Generator from a seed (a whole number >= 0), a Generator (returned as is) or
    None (fresh entropy).

    Raises
    ------
    RandomStateError
        Anything else (a negative number, a float, a bool, a legacy ``RandomState``).

    Examples
    --------
    >>> as_generator(7).integers(100) == as_generator(7).integers(100)
    np.True_
    >>> as_generator(-1)
    Traceback (most recent call last):
    ...
    maps.errors.RandomStateError: random_state must be a whole number >= 0, ... got -1
    """
    if isinstance(random_state, np.random.Generator):
        return random_state
    if random_state is None or (
        isinstance(random_state, int | np.integer)
        and not isinstance(random_state, bool)
        and random_state >= 0
    ):
        return np.random.default_rng(random_state)
    raise RandomStateError(
        f"random_state must be a whole number >= 0, a numpy Generator or None, got {random_state!r}"
    )
