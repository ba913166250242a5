"""Robot models: what a robot looks like (its footprint) and how it may move (its kinematics).

Four models, parsed from short specs by :func:`parse_robot`:

- :class:`Disc` (``disc:0.2``): a disc of a radius moving in any direction; planned by the exact
  door graph of :class:`~planners.hierarchical.HierarchicalPlanner`.
- :class:`Footprint` (``rect:0.9x0.6``): a polygon on SE(2) that moves in any direction and
  turns in place (a differential-drive or holonomic base).
- :class:`Dubins` (``dubins:radius=1,footprint=0.9x0.6``): a car that only drives forward,
  turning no tighter than ``turning_radius``.
- :class:`ReedsShepp` (``reeds-shepp:radius=1,footprint=0.9x0.6``): the same car, forward
  and in reverse.

Footprints are in the robot frame, metres, x forward; the robot's reference point (the pose
``(x, y, yaw)``) is the origin. A rectangle ``LxW`` is centred on it.

Every length (radius, side, turning radius) and every footprint point's distance from the
reference point is at most :data:`~maps.limits.MAX_ROBOT_RADIUS` (10 m, the bound of
``--robot-radius``): a mobile robot is no larger, and a larger one would only make the
planners' kernels exhaust memory.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from maps.limits import MAX_ROBOT_RADIUS
from planners.errors import PlannerParameterError

if TYPE_CHECKING:
    from ompl import base as ob


class RobotSpecError(PlannerParameterError):
    """A robot spec or model parameter that makes no sense (names the value at fault)."""


#: The tightest turning radius, metres: the collision checks along a car's arcs are spaced by
#: the turning radius over the footprint's reach, so a turn of a nanometre would check
#: billions of states; a car turning tighter than a centimetre turns in place.
MIN_TURNING_RADIUS = 0.01


def _positive(value: Any, what: str) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise RobotSpecError(f"{what} must be a number of metres, got {value!r}") from None
    if not (math.isfinite(number) and number > 0):
        raise RobotSpecError(f"{what} must be positive and finite, got {value!r}")
    if number > MAX_ROBOT_RADIUS:
        raise RobotSpecError(f"{what} must be at most {MAX_ROBOT_RADIUS:g} m, got {value!r}")
    return number


def rectangle(length: float, width: float) -> NDArray[np.float64]:
    """The corners of a ``length`` x ``width`` rectangle centred on the origin, x along
    ``length``, counter-clockwise.

    Examples
    --------
    >>> rectangle(0.6, 0.4).tolist()
    [[0.3, 0.2], [-0.3, 0.2], [-0.3, -0.2], [0.3, -0.2]]
    """
    a = _positive(length, "footprint length") / 2
    b = _positive(width, "footprint width") / 2
    return np.array([[a, b], [-a, b], [-a, -b], [a, -b]])


@dataclass(frozen=True, eq=False)
class Disc:
    """A disc robot of ``radius`` metres that moves in any direction."""

    radius: float = 0.2

    name = "disc"

    def __post_init__(self) -> None:
        _positive(self.radius, "robot radius")


@dataclass(frozen=True, eq=False)
class Footprint:
    """A polygon robot on SE(2): moves in any direction and turns in place.

    Parameters
    ----------
    polygon
        ``(n, 2)`` corners in the robot frame, metres (a simple polygon, at least 3 corners).
    """

    polygon: NDArray[np.float64]

    name = "se2"
    #: Whether the robot may cross a door either way round (it turns in place or reverses).
    reverses = True

    def __post_init__(self) -> None:
        try:
            p = np.asarray(self.polygon, float)
        except (TypeError, ValueError):  # a dict, strings, ragged corners
            p = np.zeros((0, 2))
        if p.ndim != 2 or p.shape[1] != 2 or len(p) < 3 or not np.all(np.isfinite(p)):
            raise RobotSpecError(
                f"a footprint needs 3 or more finite (x, y) corners, got {self.polygon!r}"
            )
        from shapely.geometry import Polygon

        shape = Polygon(p)
        if not shape.is_valid or shape.area <= 0:
            raise RobotSpecError(f"the footprint {p.tolist()} is not a simple polygon")
        reach = float(np.hypot(*p.T).max())
        if reach > MAX_ROBOT_RADIUS:
            raise RobotSpecError(
                f"the footprint reaches {reach:.3g} m from the robot's reference point, more "
                f"than {MAX_ROBOT_RADIUS:g} m"
            )
        p.setflags(write=False)
        object.__setattr__(self, "polygon", p)

    @property
    def circumradius(self) -> float:
        """Farthest footprint point from the reference point, metres."""
        return float(np.hypot(*self.polygon.T).max())

    @property
    def width(self) -> float:
        """Narrowest extent of the footprint over all directions (the least door it needs),
        metres."""
        from shapely.geometry import Polygon

        p = np.asarray(Polygon(self.polygon).convex_hull.exterior.coords)[:-1]
        edges = np.roll(p, -1, axis=0) - p
        normals = np.column_stack([-edges[:, 1], edges[:, 0]])
        normals /= np.hypot(*normals.T)[:, None]
        spans = p @ normals.T  # the narrowest extent is across an edge of the hull
        return float((spans.max(axis=0) - spans.min(axis=0)).min())

    @property
    def reach(self) -> float:
        """How far past a door its reference point may have to go to pass the door, metres:
        the circumradius (the footprint turning in place)."""
        return self.circumradius

    def motion_step(self, resolution: float) -> float:
        """Longest step, in the state space's distance, after which no footprint point has
        moved more than ``resolution`` metres (SE(2): metres plus half the turn, radians)."""
        return resolution / max(1.0, 2 * self.circumradius)

    def state_space(self) -> ob.StateSpace:
        """A new OMPL state space for this robot (bounds not set)."""
        from ompl import base as ob

        return ob.SE2StateSpace()


@dataclass(frozen=True, eq=False)
class Dubins(Footprint):
    """A car with a footprint that drives forward only, turning no tighter than
    ``turning_radius`` metres."""

    turning_radius: float = 1.0

    name = "dubins"
    reverses = False

    def __post_init__(self) -> None:
        super().__post_init__()
        if _positive(self.turning_radius, "turning radius") < MIN_TURNING_RADIUS:
            raise RobotSpecError(
                f"turning radius must be at least {MIN_TURNING_RADIUS:g} m (a car turning "
                "tighter turns in place: plan it as a rectangle, `rect:LxW`), got "
                f"{self.turning_radius!r}"
            )

    @property
    def reach(self) -> float:
        """The circumradius plus the turning radius (the car turning through the door),
        metres."""
        return self.circumradius + self.turning_radius

    def motion_step(self, resolution: float) -> float:
        """Longest arc, metres, after which no footprint point has moved more than
        ``resolution`` metres."""
        return resolution / (1.0 + self.circumradius / self.turning_radius)

    def state_space(self) -> ob.StateSpace:
        from ompl import base as ob

        return ob.DubinsStateSpace(self.turning_radius)


@dataclass(frozen=True, eq=False)
class ReedsShepp(Dubins):
    """A car with a footprint that drives forward and in reverse, turning no tighter than
    ``turning_radius`` metres."""

    name = "reeds-shepp"
    reverses = True

    def state_space(self) -> ob.StateSpace:
        from ompl import base as ob

        return ob.ReedsSheppStateSpace(self.turning_radius)


Robot = Disc | Footprint
#: The spec forms :func:`parse_robot` accepts.
SPECS = (
    "disc:R",
    "rect:LxW",
    "dubins:radius=R,footprint=LxW",
    "reeds-shepp:radius=R,footprint=LxW",
)


def _size(text: str, what: str) -> tuple[float, float]:
    parts = text.lower().split("x")
    if len(parts) != 2:
        raise RobotSpecError(f"{what} must be LENGTHxWIDTH in metres, got {text!r}")
    return _positive(parts[0], f"{what} length"), _positive(parts[1], f"{what} width")


def parse_robot(spec: str | Robot) -> Robot:
    """A robot model from a spec (see :data:`SPECS`); a model is returned as it is.

    Raises
    ------
    RobotSpecError
        An unknown kind, a missing or unknown parameter, a size that is not positive.

    Examples
    --------
    >>> parse_robot("disc:0.3").radius
    0.3
    >>> robot = parse_robot("reeds-shepp:radius=0.8,footprint=0.6x0.4")
    >>> robot.name, robot.turning_radius, robot.width
    ('reeds-shepp', 0.8, 0.4)
    >>> parse_robot("rect:0.6x-1")
    Traceback (most recent call last):
    ...
    planners.robots.RobotSpecError: footprint width must be positive and finite, got '-1'
    """
    if isinstance(spec, Disc | Footprint):
        return spec
    kind, _, rest = str(spec).strip().partition(":")
    kind = kind.lower()
    if kind == "disc":
        return Disc(_positive(rest.removeprefix("radius="), "robot radius"))
    if kind in ("rect", "rectangle"):
        return Footprint(rectangle(*_size(rest, "footprint")))
    if kind in ("dubins", "reeds-shepp", "reedsshepp"):
        options = dict(item.partition("=")[::2] for item in rest.split(",") if item)
        unknown = set(options) - {"radius", "footprint"}
        if unknown or "radius" not in options or "footprint" not in options:
            raise RobotSpecError(
                f"robot spec {spec!r}: give radius=R and footprint=LxW"
                + (f" (unknown: {', '.join(sorted(unknown))})" if unknown else "")
            )
        model = Dubins if kind == "dubins" else ReedsShepp
        polygon = rectangle(*_size(options["footprint"], "footprint"))
        return model(polygon, _positive(options["radius"], "turning radius"))
    raise RobotSpecError(f"unknown robot spec {spec!r}; known forms: {', '.join(SPECS)}")
