"""The demo's stages give the same results side by side in worker processes as in one."""

import subprocess
import sys
from pathlib import Path

import pytest

from topomap.cli.demo import LAST, PARALLEL, PART_OF, STAGES, run_demo, summary_rows

ROOT = Path(__file__).resolve().parents[2]
#: Numbers that are times, not results; and flat RRTConnect's paths, since OMPL seeds once per
#: process (a test process that planned before gives it other random numbers).
SKIP = {"seconds", "wall_seconds", "latency", "median_ms", "speedup", "preprocessing_s"}
SKIP |= {"flat_rrtconnect"}


def _results(summary):
    if isinstance(summary, dict):
        return {k: _results(v) for k, v in summary.items() if k not in SKIP}
    return summary


@pytest.mark.slow
def test_side_by_side_stages_give_the_results_of_one_process(tmp_path):
    together = run_demo(tmp_path / "two", size="flat", seed=2, jobs=2)
    alone = run_demo(tmp_path / "one", size="flat", seed=2, jobs=1)
    assert _results(together) == _results(alone)
    assert list(together["seconds"]) == [stage.__name__ for stage in STAGES]
    rows = summary_rows(together)
    assert [r["stage"] for r in rows] == [*together["seconds"], "total"]
    for folder in ("two", "one"):
        assert (tmp_path / folder / "segment_plan" / "segmentation.png").is_file()
        assert (tmp_path / folder / "paths.png").is_file()


def test_every_stage_after_the_first_ones_runs_once():
    parallel = [stage.__name__ for stages in PARALLEL for stage in stages]
    last = [stage.__name__ for stage in LAST]
    assert len(parallel + last) == len(set(parallel + last))
    stages = [stage.__name__ for stage in STAGES]
    assert set(parallel + last) - set(PART_OF) <= set(stages)
    assert set(PART_OF.values()) <= set(last)  # a stage whose parts ran apart ends here
    first = [name for name in stages if name not in parallel + last]
    assert first == ["generate", "drive"]


@pytest.mark.slow
def test_python_m_topomap_demo_starts_its_workers(tmp_path):
    # spawned workers import the main module again: ``python -m topomap`` must not rerun there
    done = subprocess.run(
        [sys.executable, "-m", "topomap", "-q", "demo", "--size", "flat", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=600,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""
    assert "| total |" in done.stdout
    assert (tmp_path / "paths.png").is_file()
