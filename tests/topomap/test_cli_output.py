"""What the command line shows: progress on stderr (or none with -q), one line and status 2
for bad input, a traceback for a bug, no file overwritten without --force."""

import argparse
import gc
import importlib
import json
import logging
import os
import subprocess
import sys
from pathlib import Path

import pytest

from maps.sim.floorplan import generate_floor_plan
from topomap.cli.commands.common import loading
from topomap.cli.main import main

ROOT = Path(__file__).resolve().parents[2]


def _generate(out: Path, *extra: str) -> int:
    return main(["generate", "--size", "flat", "--seed", "1", "--out", str(out), *extra])


def test_progress_goes_to_stderr_and_quiet_silences_it(tmp_path, capsys):
    assert _generate(tmp_path / "a") == 0
    shown = capsys.readouterr()
    assert "generating a flat building ..." in shown.err
    assert "spaces" in shown.out and "generating" not in shown.out
    for quiet in (["-q", "generate"], ["generate", "--quiet"]):
        argv = [*quiet, "--size", "flat", "--out", str(tmp_path / quiet[0].strip("-"))]
        assert main(argv) == 0
        assert capsys.readouterr().err == ""


def test_verbose_before_or_after_the_command_turns_on_debug_logging(tmp_path):
    logger = logging.getLogger("maps")
    try:
        for place in ("before", "after"):
            logger.setLevel(logging.NOTSET)
            argv = ["generate", "--size", "flat", "--out", str(tmp_path / place)]
            argv = ["-v", *argv] if place == "before" else [*argv, "-v"]
            assert main(argv) == 0
            assert logger.level == logging.DEBUG
    finally:
        logger.setLevel(logging.NOTSET)


def test_generate_refuses_to_overwrite_without_force(tmp_path, capsys):
    assert _generate(tmp_path) == 0
    before = (tmp_path / "rooms.json").stat().st_mtime_ns
    for written in ("map.yaml", "map.pgm"):
        (tmp_path / written).unlink()  # rooms.png and rooms.json are still there
    capsys.readouterr()
    assert _generate(tmp_path) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"topomap: error: {tmp_path / 'rooms.png'} exists; pass --force to replace it"]
    assert not (tmp_path / "map.yaml").exists()  # nothing written before refusing
    assert (tmp_path / "rooms.json").stat().st_mtime_ns == before
    assert _generate(tmp_path, "--force") == 0


@pytest.mark.parametrize(
    "command",
    [
        ["bench", "sim", "--scans", "20", "--beams", "31"],
        ["eval", "labels", "DATA"],
        ["eval", "segment", "DATA"],
        ["bench", "segment", "--sizes", "10", "--building", "flat"],
    ],
)
def test_results_are_never_overwritten_without_force(tmp_path, capsys, command):
    (tmp_path / "results.json").write_text("{}")
    argv = [str(tmp_path / "nowhere") if a == "DATA" else a for a in command]
    assert main([*argv, "--out", str(tmp_path)]) == 2
    assert "results.json exists; pass --force" in capsys.readouterr().err
    assert (tmp_path / "results.json").read_text() == "{}"


@pytest.mark.parametrize("name", ["results.json", "latency.png"])
def test_bench_online_refuses_existing_results_before_any_work(tmp_path, capsys, monkeypatch, name):
    import topomap.cli.bench_online as bench_online

    ran = []
    real = bench_online.bench_latency
    monkeypatch.setattr(bench_online, "bench_latency", lambda **kw: ran.append(1) or real(**kw))
    argv = ["bench", "online", "--parts", "latency", "--keyframes", "120", "--seed-keyframes"]
    argv += ["100", "--building", "flat", "--offline-up-to", "0", "--out", str(tmp_path)]
    (tmp_path / name).write_text("mine")
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"topomap: error: {tmp_path / name} exists; pass --force to replace it"]
    assert ran == [] and [p.name for p in tmp_path.iterdir()] == [name]
    assert (tmp_path / name).read_text() == "mine"
    assert main([*argv, "--force"]) == 0
    assert ran == [1] and (tmp_path / "latency.png").read_bytes().startswith(b"\x89PNG")
    results = json.loads((tmp_path / "results.json").read_text())
    assert results["latency"]["summary"]["keyframes"] == 120


def test_bench_online_refuses_latency_png_only_when_it_draws_it(tmp_path, capsys):
    (tmp_path / "latency.png").write_text("mine")
    argv = ["bench", "online", "--parts", "growing", "--snapshots", str(tmp_path / "nowhere")]
    assert main([*argv, "--out", str(tmp_path)]) == 2  # past the check, to the missing data
    assert "data folder not found" in capsys.readouterr().err


def test_a_benchmark_file_failing_mid_write_leaves_the_old_one_whole(tmp_path, monkeypatch):
    from topomap.cli.plan_report import write_ompl_log

    record = {"planner": "flat", "seconds": 0.1, "success": True, "length_m": 2.0}
    record |= {"optimal_m": 1.0, "collisions": 0, "query": 0, "map": "rooms"}
    log = write_ompl_log(tmp_path / "rooms.log", "rooms", [record], 5.0)
    old = log.read_text()

    def full_disk(self, text, *args, **kwargs):
        with self.open("w") as stream:
            stream.write(text[: len(text) // 2])
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(Path, "write_text", full_disk)
    with pytest.raises(OSError, match="No space left"):
        write_ompl_log(log, "rooms", [record, {**record, "query": 1}], 5.0)
    assert log.read_text() == old
    assert [p.name for p in tmp_path.iterdir()] == ["rooms.log"]


def test_a_bug_keeps_its_traceback(tmp_path, monkeypatch):
    def broken(args):
        raise RuntimeError("a bug, not bad input")

    monkeypatch.setattr(
        importlib.import_module("topomap.cli.commands.generate"), "cmd_generate", broken
    )
    with pytest.raises(RuntimeError, match="a bug"):
        _generate(tmp_path)


def test_usage_errors_return_two(capsys):
    assert main(["plan", "map.yaml", "--start", "1,x", "--goal", "2,2"]) == 2
    assert "argument --start: expected X,Y in metres, got '1,x'" in capsys.readouterr().err
    assert main(["--help"]) == 0


@pytest.mark.parametrize(
    ("argv", "shown"),
    [
        (["nosuch"], "topomap: error: argument command: invalid choice: 'nosuch'"),
        (["-x"], "topomap: error: the following arguments are required: command"),
        (["segment", "m.yaml"], "topomap segment: error: the following arguments are required"),
        (["segment", "m.yaml", "--out", "o", "--nope"], "topomap segment: error: unrecognized"),
        (["eval", "segment", "d", "--bad", "1"], "topomap eval segment: error: unrecognized"),
        (
            ["eval", "segment", "d", "--out"],
            "topomap eval segment: error: argument --out: expected",
        ),
        (["bench", "seg"], "topomap bench: error: argument bench: invalid choice: 'seg'"),
        (["bench", "sim", "--scans", "x"], "topomap bench sim: error: argument --scans: must be"),
        (
            ["plan", "m.yaml", "--start", "1,x", "--goal", "2"],
            "topomap plan: error: argument --start",
        ),
    ],
)
def test_usage_errors_are_one_line_naming_the_command(capsys, argv, shown):
    # as every other error of the command line: no usage, which --help prints
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(shown), err
    assert err[0].endswith(f"(see {shown.split(': error')[0]} --help)")


def test_help_still_prints_the_usage_and_every_option(capsys):
    from topomap.cli.main import Parser, build_parser

    assert main(["segment", "--help"]) == 0
    shown = capsys.readouterr().out
    assert shown.startswith("usage: topomap segment") and "--robot-radius" in shown

    def parsers(parser):  # every command's parser, subcommands' too
        yield parser
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for sub in action.choices.values():
                    yield from parsers(sub)

    found = list(parsers(build_parser()))
    assert len(found) > 20 and all(type(p) is Parser for p in found)


@pytest.mark.slow
def test_the_console_command_prints_one_line_for_bad_input_and_nothing_at_exit(tmp_path):
    def topomap(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(
            [sys.executable, "-m", "topomap", *args],
            capture_output=True,
            text=True,
            cwd=ROOT,
            timeout=300,
            check=False,
        )

    done = topomap("generate", "--size", "flat", "--out", str(tmp_path))
    assert done.returncode == 0, done.stderr
    again = topomap("generate", "--size", "flat", "--out", str(tmp_path))
    assert again.returncode == 2
    assert again.stderr.strip().splitlines() == [
        f"topomap: error: {tmp_path / 'map.yaml'} exists; pass --force to replace it"
    ]
    # planning loads OMPL; its bindings must have nothing left to report at exit
    planned = topomap(
        "-q",
        "plan",
        str(tmp_path / "map.yaml"),
        "--start=2,2",
        "--goal=10,8",
        "--compare",
        "--draw",
        str(tmp_path / "path.png"),
    )
    assert planned.returncode == 0, planned.stderr
    assert planned.stderr == ""


def test_pictures_are_drawn_without_pyplot(tmp_path):
    # the Figure API: no pyplot state, no backend chosen for the user's program
    code = (
        "import sys, numpy as np; from maps.grid import OccupancyGrid; "
        "from topomap.cli.drawing import draw_map; "
        "grid = OccupancyGrid(np.zeros((20, 30), np.int8), 0.1); "
        f"draw_map({str(tmp_path / 'map.png')!r}, grid); "
        "print('matplotlib.pyplot' in sys.modules)"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["False"]
    assert (tmp_path / "map.png").stat().st_size > 1000


def test_segment_loads_only_the_libraries_it_uses(tmp_path):
    # its wall time is half imports: the parser loads no library (nor the batch driver), the
    # command none of those only other commands use (plotting, learning, classifier files,
    # planning, bags, clusters, progress bars) nor what only --previous does (the FFT that
    # lays one map on another)
    generate_floor_plan("flat", random_state=0).grid.save(tmp_path / "flat.yaml")
    parser = ("numpy", "scipy", "networkx", "cv2", "topomap.cli.batch")
    others = (
        *("matplotlib", "PIL", "sklearn", "joblib", "skops", "ompl"),
        *("rosbags", "dask", "distributed", "selenium", "tqdm"),
        *("maps.registration", "scipy.fft"),
    )
    code = (
        "import sys; from topomap.cli.main import build_parser, main; "
        f"args = ['-q', 'segment', {str(tmp_path / 'flat.yaml')!r}, '--out', "
        f"{str(tmp_path / 'out')!r}]; build_parser().parse_args(args); "
        f"print([m for m in {parser} if m in sys.modules]); "
        f"main(args); print([m for m in {others} if m in sys.modules])"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0] == "[]" and lines[-1] == "[]"
    assert (tmp_path / "out" / "segmentation.png").exists()


def test_the_command_line_exits_without_collecting_the_imports():
    # the collector frozen before the interpreter shuts down (0.15 s of `topomap segment`)
    code = (
        "import atexit, gc, sys; from topomap.cli.main import run; "
        "atexit.register(lambda: print(gc.get_freeze_count() > 0)); "
        "sys.argv = ['topomap', '--help']; run()"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1] == "True"


def test_segment_imports_its_libraries_without_collecting_them(tmp_path):
    # the collector went 8 to 15 times over the older generations the imports fill (40 ms)
    generate_floor_plan("flat", random_state=0).grid.save(tmp_path / "flat.yaml")
    code = (
        "import gc, sys; from topomap.cli.main import run; older = []; "
        "gc.callbacks.append(lambda phase, info: older.append(info['generation']) "
        "if phase == 'stop' and info['generation'] else None); "
        "import atexit; atexit.register(lambda: print(len(older))); "
        f"sys.argv = ['topomap', '-q', 'segment', {str(tmp_path / 'flat.yaml')!r}, "
        f"'--out', {str(tmp_path / 'out')!r}]; run()"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert int(done.stdout.splitlines()[-1]) <= 2


def test_loading_pauses_the_collector_and_freezes_only_in_the_console_script():
    frozen = gc.get_freeze_count()
    with loading():
        assert not gc.isenabled()
    assert gc.isenabled() and gc.get_freeze_count() == frozen


def _python_with(name: str, given: str | None, code: str) -> str:
    """What ``python -c code`` prints with the environment variable ``name`` unset (None) or
    set to ``given``."""
    env = {k: v for k, v in os.environ.items() if k != name}
    if given is not None:
        env[name] = given
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, env=env, timeout=120
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


@pytest.mark.parametrize("given", [None, "2"])
def test_the_command_line_runs_blas_in_one_thread_unless_told(given):
    # NumPy's, SciPy's and OpenCV's OpenBLAS each start threads that spin (0.1 s of start-up)
    code = (
        "import os, topomap.cli.main, topomap.topomap, cv2; "
        "from threadpoolctl import threadpool_info; "
        "print(os.environ['OPENBLAS_NUM_THREADS'], len(threadpool_info()), "
        "max(i['num_threads'] for i in threadpool_info()))"
    )
    value, libraries, most = _python_with("OPENBLAS_NUM_THREADS", given, code).split()
    assert value == (given or "1") and int(libraries) >= 1
    assert given is not None or most == "1"


@pytest.mark.parametrize("given", [None, "1"])
def test_the_command_line_asks_for_no_huge_pages_unless_told(given):
    # with transparent huge pages on request, each new large array waited for 2 MB pages
    code = (
        "import topomap.cli.main, numpy; "
        "print(numpy._core.multiarray._set_madvise_hugepage(False))"  # returns the setting
    )
    shown = _python_with("NUMPY_MADVISE_HUGEPAGE", given, code)
    assert shown.split()[-1] == ("True" if given else "False")


@pytest.mark.parametrize(("argv", "jobs"), [([], -1), (["--jobs", "3"], 3)])
def test_segment_partitions_a_large_maps_blocks_on_every_core_unless_told(
    tmp_path, monkeypatch, argv, jobs
):
    from topomap.topomap import TopoMap

    seen = {}

    def from_grid(grid, **options):
        seen.update(options)
        raise SystemExit(0)

    monkeypatch.setattr(TopoMap, "from_grid", staticmethod(from_grid))
    generate_floor_plan("flat", random_state=0).grid.save(tmp_path / "map.yaml")
    with pytest.raises(SystemExit):
        main(["-q", "segment", str(tmp_path / "map.yaml"), "--out", str(tmp_path / "o"), *argv])
    assert seen["n_jobs"] == jobs
