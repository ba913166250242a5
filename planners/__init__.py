"""Planners on occupancy grids and region graphs: the hierarchical planner
(:class:`HierarchicalPlanner`: the region graph first, then OMPL inside each submap), the flat
OMPL baseline (:class:`FlatPlanner`), the reference planners (:class:`GridAStar`, the exact
:class:`VisibilityGraph`), the shared validity rule (:class:`Workspace`) and planned paths
(:class:`PlannedPath`). Names are imported lazily: OMPL is loaded only with the first planner that
uses it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from maps import _exports

if TYPE_CHECKING:  # the names as type checkers see them (``as``: re-exported)
    from planners.errors import InvalidQueryError as InvalidQueryError
    from planners.errors import NoPathError as NoPathError
    from planners.errors import PlannerParameterError as PlannerParameterError
    from planners.errors import PlanningError as PlanningError
    from planners.flat import FlatPlanner as FlatPlanner
    from planners.grid_astar import GridAStar as GridAStar
    from planners.grid_mcp import GridMCP as GridMCP
    from planners.hierarchical import HierarchicalPlanner as HierarchicalPlanner
    from planners.nav2_route import RouteGraphError as RouteGraphError
    from planners.nav2_route import read_nav2_route as read_nav2_route
    from planners.nav2_route import write_nav2_route as write_nav2_route
    from planners.path import PlannedPath as PlannedPath
    from planners.region_route import RegionRoute as RegionRoute
    from planners.visibility import VisibilityGraph as VisibilityGraph
    from planners.workspace import Workspace as Workspace


def __getattr__(name: str) -> Any:
    return _exports.load(__name__, name)


def __dir__() -> list[str]:
    return _exports.names(__name__)
