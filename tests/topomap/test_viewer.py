"""`topomap view`: the HTML page in a real headless Chromium (Debian's chromium and
chromium-driver, Selenium). Missing on a developer machine they skip with the reason; with
``CI`` set the test installs them with apt-get, and fails if it cannot."""

import math
import os
import re
import shutil
import subprocess

import networkx as nx
import pytest

from maps.sim.floorplan import generate_floor_plan
from topomap.cli.main import main
from topomap.cli.viewer import viewer_data
from topomap.topomap import TopoMap

PACKAGES = ["chromium", "chromium-driver"]


def _binaries():
    browser = next(filter(None, map(shutil.which, ["chromium", "chromium-browser"])), None)
    return browser, shutil.which("chromedriver")


def _install_in_ci():
    """apt-get the browser and its driver (CI runs as root on a fresh Debian machine)."""
    if shutil.which("apt-get") is None:
        pytest.fail(f"CI: no browser and no apt-get to install {PACKAGES}")
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    for command in (["apt-get", "update", "-qq"], ["apt-get", "install", "-y", "-qq", *PACKAGES]):
        done = subprocess.run(command, env=env, capture_output=True, text=True, timeout=1200)
        if done.returncode != 0:
            pytest.fail(f"CI: {' '.join(command)} failed: {done.stderr[-2000:]}")


@pytest.fixture(scope="module")
def chrome():
    browser, driver = _binaries()
    if browser is None or driver is None:
        if not os.environ.get("CI"):
            pytest.skip(f"headless Chromium not found: apt-get install {' '.join(PACKAGES)}")
        _install_in_ci()
        browser, driver = _binaries()
        if browser is None or driver is None:
            pytest.fail(f"CI: {PACKAGES} installed but chromium or chromedriver not on PATH")
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = browser
    for argument in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage"):
        options.add_argument(argument)
    options.add_argument("--window-size=1280,800")
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    session = webdriver.Chrome(service=Service(executable_path=driver), options=options)
    yield session
    session.quit()


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    folder = tmp_path_factory.mktemp("view")
    plan = generate_floor_plan("flat", random_state=0)
    topo = TopoMap.from_grid(plan.grid, random_state=0)
    topo.save(folder / "regions")
    out = folder / "map.html"
    assert main(["-q", "view", str(folder / "regions"), "--out", str(out)]) == 0
    return topo, out


def _pointer(chrome, x, y, *, click=False):
    from selenium.webdriver.common.actions.action_builder import ActionBuilder

    actions = ActionBuilder(chrome)
    actions.pointer_action.move_to_location(round(x), round(y))
    if click:
        actions.pointer_action.click()
    actions.perform()


def _screen(chrome, point):
    return chrome.execute_script(
        "return window.topomap.toScreen(arguments[0], arguments[1])", *point
    )


def test_the_page_is_one_file_with_no_network(page):
    _, out = page
    text = out.read_text()
    assert not re.search(r"""(src|href)=["']?(https?:)?//""", text)
    assert "fetch(" not in text and "XMLHttpRequest" not in text
    assert text.count("<script") == 2 and "data:image/png;base64," in text
    assert main(["-q", "view", str(out.parent / "regions"), "--out", str(out)]) == 2  # exists


def test_page_in_chromium_names_hover_route_and_zoom(chrome, page, tmp_path):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.actions.wheel_input import ScrollOrigin
    from selenium.webdriver.common.by import By

    topo, out = page
    chrome.get(out.as_uri())
    assert chrome.execute_script("return typeof window.topomap") == "object"
    errors = [e for e in chrome.get_log("browser") if e["level"] in ("SEVERE", "WARNING")]
    assert errors == []
    names = {topo.graph.nodes[r]["name"] for r in topo.graph.nodes}
    listed = [li.text for li in chrome.find_elements(By.CSS_SELECTOR, "#regions li")]
    assert {text.rsplit(" (", 1)[0] for text in listed} == names
    drawn = chrome.execute_script("return window.topomap.state.drawnNames")
    assert set(drawn) <= names and len(drawn) >= len(names) // 2

    planner = topo.planner(0.2)
    points = {int(k): v for k, v in viewer_data(topo)["points"].items()}
    for region in sorted(points)[:4]:  # the tooltip names the region under the pointer
        point = points[region]
        _pointer(chrome, *_screen(chrome, point))
        tooltip = chrome.find_element(By.ID, "tooltip")
        assert tooltip.is_displayed()
        assert int(tooltip.get_attribute("data-id")) == topo.region_at(*point) == region
        assert topo.graph.nodes[region]["name"] in tooltip.text
        area = float(re.search(r"([0-9.]+) m²", tooltip.text).group(1))
        assert area == pytest.approx(topo.graph.nodes[region]["area_m2"], abs=0.051)

    a, b = min(points), max(points)
    for region in (a, b):
        _pointer(chrome, *_screen(chrome, points[region]), click=True)
    state = chrome.execute_script("return window.topomap.state")
    assert state["selected"] == [a, b]
    route = [step["id"] for step in state["route"]]
    assert route[0] == a and route[-1] == b and nx.is_path(topo.graph, route)
    expected = planner.plan(points[a], points[b])
    assert state["pathSource"] == "planned"
    assert state["path"][0] == pytest.approx(list(points[a]), abs=1e-3)
    assert state["pathLength"] == pytest.approx(expected.length, abs=0.01)
    text = chrome.find_element(By.ID, "route").text
    assert topo.graph.nodes[a]["name"] in text and f"{expected.length:.1f} m" in text
    chrome.save_screenshot(str(tmp_path / "viewer.png"))

    x, y = _screen(chrome, points[a])
    before = chrome.execute_script(
        "return [window.topomap.view.scale, ...window.topomap.toWorld(arguments[0], arguments[1])]",
        x,
        y,
    )
    ActionChains(chrome).scroll_from_origin(
        ScrollOrigin.from_viewport(round(x), round(y)), 0, -400
    ).perform()
    after = chrome.execute_script(
        "return [window.topomap.view.scale, ...window.topomap.toWorld(arguments[0], arguments[1])]",
        round(x),
        round(y),
    )
    assert after[0] > 1.5 * before[0]  # zoomed in around the pointer
    assert math.dist(before[1:], after[1:]) < 3 / after[0] + 3 / before[0]
    chrome.save_screenshot(str(tmp_path / "viewer-zoomed.png"))
    assert chrome.get_log("browser") == []


def test_the_page_shows_a_canvas_maps_known_part_where_its_cells_are():
    """A SLAM package's canvas (here 3 x the flat's size, the origin turned 0.3 rad): the page
    opens on the building and its picture is of the known part and 1 m round it (it was the
    whole canvas: the building small in a corner, and 2 GB to draw an 8000 x 8000 canvas);
    each pixel still lands on its own cell (the page's transform, from the data)."""
    import base64

    import cv2
    import numpy as np

    from maps.grid import OccupancyGrid
    from topomap.cli.drawing import FRAME, map_image
    from topomap.graph_layout import label_colour

    flat = generate_floor_plan("flat", random_state=0).grid
    cells = np.full((3 * flat.shape[0], 3 * flat.shape[1]), -1, np.int8)
    top, left = flat.shape[0] // 2, 2 * flat.shape[1]
    cells[top : top + flat.shape[0], left : left + flat.shape[1]] = flat.cells
    grid = OccupancyGrid(cells, flat.resolution, (-50.0, 20.0, 0.3))
    topo = TopoMap.from_grid(grid, random_state=0)
    data = viewer_data(topo, max_paths=0)
    rows, cols = grid.known_box(FRAME)
    assert data["bounds"] == list(grid.cropped(rows, cols).bounds())
    encoded = base64.b64decode(data["image"].split(",", 1)[1])
    image = cv2.imdecode(np.frombuffer(encoded, np.uint8), cv2.IMREAD_UNCHANGED)
    assert data["image_step"] == 1 and image.shape[:2] == (
        rows.stop - rows.start,
        cols.stop - cols.start,
    )
    colours = np.zeros((len(topo.graph) + 1, 4))
    for region, label in topo.graph.nodes(data="label"):
        colours[region] = (*label_colour(label), 1.0)
    whole = map_image(grid, topo.regions.labels, alpha=0.55, colours=colours)
    whole = cv2.cvtColor(whole, cv2.COLOR_RGBA2BGRA)
    assert len({tuple(c) for c in whole[topo.regions.labels > 0]}) >= 2  # rooms, corridors
    ox, oy, yaw = data["origin"]
    cell, height = data["resolution"], data["height"]
    free_rows, free_cols = np.nonzero(topo.regions.labels > 0)
    pick = np.random.default_rng(0).choice(len(free_rows), 500, replace=False)
    x, y = grid.cell_to_world(free_rows[pick], free_cols[pick])
    c, s = math.cos(yaw), math.sin(yaw)  # the page: translate(ox, oy), rotate(yaw), flip rows
    u, v = c * (x - ox) + s * (y - oy), -s * (x - ox) + c * (y - oy)
    px, py = np.floor(u / cell).astype(int), np.floor((height * cell - v) / cell).astype(int)
    drawn = image[py, px]  # the page's colour there: the region of that cell, in its colour
    assert np.array_equal(drawn, whole[free_rows[pick], free_cols[pick]])
