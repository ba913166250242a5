"""The public API: lazy exports, the error tree, a quick import without OMPL."""

import ast
import importlib
import pickle
import subprocess
import sys
from pathlib import Path

import pytest

import maps
import planners
import segmentation
import topomap
from maps.errors import MapError, MapsError, OutputExistsError, TopomapError
from planners.errors import InvalidQueryError, NoPathError, PlannerParameterError, PlanningError
from segmentation.errors import ExportFormatError, ParameterError, SegmentationError
from topomap.errors import LabelError

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = [topomap, maps, segmentation, planners]


def _fresh_python(code: str) -> str:
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120
    )
    assert done.returncode == 0, done.stderr
    return done.stdout.strip()


def test_the_front_door_does_not_load_ompl():
    code = "from topomap import TopoMap; import sys; print('ompl' in sys.modules)"
    assert _fresh_python(code) == "False"


def test_import_topomap_imports_none_of_the_packages():
    names = "('maps', 'segmentation', 'planners', 'numpy')"
    code = f"import sys, topomap; print([p for p in {names} if p in sys.modules])"
    assert _fresh_python(code) == "[]"


def test_planners_load_ompl_only_with_a_planner():
    code = (
        "import sys, planners; planners.Workspace; a = 'ompl' in sys.modules; "
        "planners.FlatPlanner; print(a, 'ompl' in sys.modules)"
    )
    assert _fresh_python(code) == "False True"


@pytest.mark.parametrize("package", PACKAGES, ids=lambda p: p.__name__)
def test_every_exported_name_resolves_and_is_listed(package):
    for name in package.__all__:
        value = getattr(package, name)
        assert value is not None
        assert name in dir(package)
    with pytest.raises(AttributeError, match="has no attribute 'nothing_here'"):
        package.nothing_here  # noqa: B018


@pytest.mark.parametrize("package", PACKAGES, ids=lambda p: p.__name__)
def test_the_re_export_lines_are_the_exports(package):
    # what type checkers see (the ``from m import x as x`` lines) is what the package gives
    tree = ast.parse(Path(package.__file__).read_text())
    block = next(
        node
        for node in tree.body
        if isinstance(node, ast.If) and getattr(node.test, "id", "") == "TYPE_CHECKING"
    )
    seen = {
        alias.name: node.module
        for node in [*tree.body, *block.body]
        if isinstance(node, ast.ImportFrom) and node.module
        for alias in node.names
        if alias.asname == alias.name
    }
    assert sorted(seen) == package.__all__
    for name, module in seen.items():
        assert getattr(importlib.import_module(module), name) is getattr(package, name)


def test_wander_is_the_function_even_after_its_module_is_imported():
    importlib.import_module("maps.sim.exploration")
    assert callable(maps.wander)
    assert maps.wander.__module__ == "maps.sim.exploration"


@pytest.mark.parametrize(
    ("error", "builtin"),
    [
        (MapError, Exception),
        (SegmentationError, ValueError),
        (ParameterError, ValueError),
        (ExportFormatError, ValueError),
        (PlanningError, Exception),
        (InvalidQueryError, ValueError),
        (PlannerParameterError, ValueError),
        (NoPathError, Exception),
        (LabelError, ValueError),
        (OutputExistsError, FileExistsError),
        (maps.MapFileNotFoundError, FileNotFoundError),
        (maps.MapFormatError, ValueError),
    ],
)
def test_every_error_is_a_topomap_error_and_its_builtin(error, builtin):
    assert issubclass(error, TopomapError) and issubclass(error, builtin)


def test_the_package_roots_are_distinct_branches():
    roots = [MapError, SegmentationError, PlanningError, LabelError]
    for a in roots:
        for b in roots:
            assert issubclass(a, b) == (a is b)
    assert MapsError is MapError
    assert topomap.TopomapError is TopomapError and topomap.TopoMap.__name__ == "TopoMap"


def test_typed_packages_ship_py_typed():
    for package in PACKAGES:
        assert (Path(package.__file__).parent / "py.typed").is_file()


def test_file_errors_print_their_message_and_survive_pickling():
    # a batch run ships errors between processes
    missing = maps.MapFileNotFoundError("maps/lab.yaml", "map YAML")
    taken = OutputExistsError("out/map.yaml", "--force")
    assert (
        str(missing) == "map YAML not found: maps/lab.yaml" and missing.filename == "maps/lab.yaml"
    )
    assert str(taken) == "out/map.yaml exists; pass --force to replace it"
    for error in (missing, taken):
        again = pickle.loads(pickle.dumps(error))
        assert type(again) is type(error) and str(again) == str(error)
        assert again.errno == error.errno and again.filename == error.filename


def test_every_folder_of_modules_is_a_package_a_wheel_keeps():
    # setuptools' find (pyproject.toml) leaves out a folder without __init__.py
    for name in ("maps", "segmentation", "planners", "topomap"):
        for folder in {p.parent for p in (ROOT / name).rglob("*.py")}:
            assert (folder / "__init__.py").is_file(), folder
