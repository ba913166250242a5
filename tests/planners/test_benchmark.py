"""The planning benchmark's records, budgets and OMPL benchmark logs."""

import sqlite3

import numpy as np
import pytest

from planners.benchmark import far_queries, run_queries, summarise
from planners.grid_mcp import GridMCP
from planners.visibility import VisibilityGraph
from planners.workspace import Workspace
from topomap.cli.plan_report import write_ompl_log


@pytest.fixture
def space(two_rooms):
    return Workspace(two_rooms(), 0.2)


def test_grid_search_is_valid_and_within_the_octile_bound(space):
    grid, reference = GridMCP(space), VisibilityGraph(space)
    for start, goal in far_queries(space, 5, random_state=0):
        path, exact = grid.plan(start, goal), reference.plan(start, goal).length
        assert np.allclose(path.waypoints[[0, -1]], [start, goal])
        assert space.collisions(path.waypoints) == 0
        # 8-connected steps: at most 1.0824 x the straight run, plus a cell at each end
        assert exact - 1e-9 <= path.length <= 1.0824 * exact + 2 * space.grid.resolution


def test_budget_skips_the_queries_of_a_slow_planner(space):
    pairs = far_queries(space, 4, random_state=1)
    optimal = [VisibilityGraph(space).plan(s, g).length for s, g in pairs]
    records, skipped = run_queries("rooms", space, [GridMCP(space)], optimal, pairs, budget=0.0)
    assert len(records) == 1 and skipped == {"grid_mcp": 3}


def test_ompl_log_loads_into_the_planner_arena_database(space, tmp_path):
    tools = pytest.importorskip("ompl.tools")
    pairs = far_queries(space, 3, random_state=2)
    optimal = [VisibilityGraph(space).plan(s, g).length for s, g in pairs]
    records, _ = run_queries("rooms", space, [GridMCP(space)], optimal, pairs)
    records.append(dict(records[0], planner="broken", success=False, length_m=None))
    log = write_ompl_log(tmp_path / "rooms.log", "rooms", records, 5.0, seed=7)
    database = tmp_path / "arena.db"
    tools.readBenchmarkLog(str(database), [str(log)], False)
    with sqlite3.connect(database) as db:
        assert db.execute("SELECT name, seed FROM experiments").fetchall() == [("rooms", "7")]
        planners = dict(db.execute("SELECT id, name FROM plannerConfigs").fetchall())
        rows = db.execute("SELECT plannerid, solved, solution_length, time FROM runs").fetchall()
    assert sorted(planners.values()) == ["broken", "grid_mcp"]
    solved = [r for r in rows if planners[r[0]] == "grid_mcp"]
    assert len(solved) == 3 and all(r[1] == 1 for r in solved)
    assert [r[2] for r in solved] == pytest.approx([r["length_m"] for r in records[:3]])
    (failed,) = [r for r in rows if planners[r[0]] == "broken"]
    assert failed[1] == 0 and failed[2] is None


def test_the_footprint_picture_draws_the_hierarchical_paths(two_rooms, tmp_path):
    from topomap.cli.plan_report import plot_footprint_paths

    grid = two_rooms()
    yaml = grid.save(tmp_path / "rooms.yaml")
    xmin, ymin, xmax, _ = grid.bounds()
    poses = [[xmin + 1.0, ymin + 1.0, 0.0], [xmax - 1.0, ymin + 1.0, 0.5]]
    about = {
        "footprint": [[0.3, 0.2], [-0.3, 0.2], [-0.3, -0.2], [0.3, -0.2]],
        "maps": {"rooms": str(yaml)},
        "paths": [
            {"map": "rooms", "query": 0, "planner": "hierarchical", "poses": poses},
            {"map": "rooms", "query": 0, "planner": "flat_rrtconnect", "poses": poses},
        ],
    }
    written = plot_footprint_paths(tmp_path / "paths.png", about)
    assert written.stat().st_size > 10_000


def test_speedup_per_query_pairs_the_same_queries():
    seconds = {"hierarchical": [1.0, 2.0, 4.0], "grid_mcp": [10.0, 4.0, 400.0]}
    records = [
        {"map": "m", "planner": name, "query": q, "seconds": t, "success": True,
         "length_m": 1.0, "optimal_m": 1.0, "collisions": 0}
        for name, times in seconds.items()
        for q, t in enumerate(times)
    ]  # fmt: skip
    rows = {row["planner"]: row for row in summarise(records)}
    assert rows["grid_mcp"]["speedup_query"] == 10.0  # ratios 10, 2, 100
    assert rows["grid_mcp"]["speedup"] == 5.0  # median 10 over median 2
    assert rows["hierarchical"]["speedup_query"] == 1.0
