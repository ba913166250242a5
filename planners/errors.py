"""Errors raised by the planners; each names the query or the value at fault."""

from __future__ import annotations

from maps.errors import TopomapError


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
