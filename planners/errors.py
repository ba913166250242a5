"""Errors raised by the planners; each names the query or the value at fault."""

from __future__ import annotations

from maps.errors import TopomapError
from maps.limits import finite_in

#: Seconds a planner may be given for one query at most: a day.
MAX_SECONDS = 86_400.0


class PlanningError(TopomapError):
    """Base class of every error raised by :mod:`planners`."""


class PlannerParameterError(PlanningError, ValueError):
    """A planner option or input that makes no sense: an unknown OMPL planner, a time limit
    that is not positive, a label image whose shape is not the map's."""


class InvalidQueryError(PlanningError, ValueError):
    """A start or goal that cannot be planned from: off the map, in a wall, unknown, or a
    region name or id that does not exist."""


class NoPathError(PlanningError):
    """No collision-free path joins start and goal (disconnected, or every door closed)."""


class StaleDoorGraphError(PlanningError, ValueError):
    """A prepared door graph made for another map, other regions or another robot radius
    than the planner it is given to (:mod:`planners.prepared`)."""


class DoorGraphFileError(PlanningError, ValueError):
    """A saved door graph file that cannot be read: not one, damaged, or written by a newer
    topomap (:func:`planners.prepared.read_prepared`)."""


def checked_time_limit(time_limit: object) -> float:
    """``time_limit`` in seconds, once it is a number in (0, :data:`MAX_SECONDS`].

    Examples
    --------
    >>> checked_time_limit(5)
    5.0
    >>> checked_time_limit("x")
    Traceback (most recent call last):
    ...
    planners.errors.PlannerParameterError: time_limit must be a number, got 'x'
    """
    problem = finite_in(time_limit, "time_limit", 0.0, MAX_SECONDS, unit="s", low_open=True)
    if problem is not None:
        raise PlannerParameterError(problem)
    return float(time_limit)  # type: ignore[arg-type]
