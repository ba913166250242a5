"""Errors raised by the planners; each names the query or the value at fault."""

from __future__ import annotations


class PlanningError(Exception):
    """Base class of every error raised by :mod:`planners`."""


class InvalidQueryError(PlanningError, ValueError):
    """A start or goal that cannot be planned from: off the map, in a wall, unknown, or a
    region name or id that does not exist."""


class NoPathError(PlanningError):
    """No collision-free path joins start and goal (disconnected, or every door closed)."""
