"""Evaluation of region labelling against place types drawn by people (``ipa_places``) and
against the generator's own room types.

Each map is segmented; each region's true type is the majority type of its cells; regions are
then predicted by the rules, and by a random forest trained on all *other* labelled maps (whole
maps left out; with ``more``, the other data set's maps too). Scores are per region, and per
map the corridors found and invented.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import networkx as nx
import numpy as np
from numpy.typing import NDArray
from sklearn.metrics import confusion_matrix, precision_recall_fscore_support

from maps.errors import MapFileNotFoundError
from maps.floorplan import generate_floor_plan
from maps.grid import OccupancyGrid
from segmentation.regions import Regions
from topomap.cli.drawing import _map_figure, _save
from topomap.labels import (
    PLACE_TYPES,
    ForestClassifier,
    feature_matrix,
    region_features,
    rule_classifier,
)
from topomap.topomap import TopoMap

#: Grey levels of ``*_places.png``: room, corridor, doorway.
PLACE_GREYS = {77: "room", 115: "corridor", 179: "doorway"}
#: Cell size of the ipa_places images, metres.
PLACES_RESOLUTION = 0.05


def place_maps(data_dir: str | Path) -> list[tuple[str, Path, Path]]:
    """``(name, floor plan PNG, places PNG)`` for every ``NAME.png`` with ``NAME_places.png``."""
    folder = Path(data_dir)
    if not folder.is_dir():
        raise MapFileNotFoundError(folder, "data folder")
    found = []
    for places in sorted(folder.glob("*_places.png")):
        name = places.name.removesuffix("_places.png")
        plan = folder / f"{name}.png"
        if plan.exists():
            found.append((name, plan, places))
    if not found:
        raise MapFileNotFoundError(folder / "*_places.png", "place-labelled map")
    return found


def read_places(path: Path) -> NDArray[np.int8]:
    """Place type index (into :data:`PLACE_TYPES`) per pixel, -1 for walls and other greys."""
    image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise MapFileNotFoundError(path, "places image")
    types = np.full(image.shape, -1, np.int8)
    for grey, place in PLACE_GREYS.items():
        types[image == grey] = PLACE_TYPES.index(place)
    return types


def majority_types(labels: NDArray[np.integer], truth: NDArray[np.int8], ids: NDArray) -> list:
    """The most common true type among each region's cells (None when it has none)."""
    found = []
    for region in ids:
        cells = truth[(labels == region) & (truth >= 0)]
        counts = np.bincount(cells, minlength=len(PLACE_TYPES))
        found.append(PLACE_TYPES[int(counts.argmax())] if counts.sum() else None)
    return found


def labelled_regions(
    regions: Regions, graph: nx.Graph, truth: NDArray[np.int8], map_name: str
) -> dict[str, Any]:
    """Features and true type of every region of ``graph`` with a true type, and the map's
    ``regions`` and ``graph`` for pictures."""
    features = region_features(regions, graph)
    types = majority_types(regions.labels, truth, features["id"].astype(int))
    keep = np.array([t is not None for t in types])
    return {
        "map": map_name,
        "features": {k: v[keep] for k, v in features.items()},
        "truth": [t for t in types if t is not None],
        "regions": regions,
        "graph": graph,
    }


def ipa_places_regions(
    data_dir: str | Path, progress: Callable[[Any], Any] = iter
) -> list[dict[str, Any]]:
    """:func:`labelled_regions` of every map of ``ipa_places``."""
    found = []
    for name, plan, places in progress(place_maps(data_dir)):
        grid = OccupancyGrid.from_image(plan, PLACES_RESOLUTION)
        topo = TopoMap.from_grid(grid)
        found.append(labelled_regions(topo.regions, topo.graph, read_places(places), name))
    return found


def generated_regions(
    sizes: tuple[str, ...] = ("flat", "office"),
    seeds: tuple[int, ...] = (0, 1, 2),
    progress: Callable[[Any], Any] = iter,
) -> list[dict[str, Any]]:
    """:func:`labelled_regions` of generated buildings, the truth being the generator's
    room types."""
    found = []
    for size, seed in progress([(size, seed) for size in sizes for seed in seeds]):
        plan = generate_floor_plan(size, random_state=seed)
        truth = np.full(plan.labels.shape, -1, np.int8)
        for index, place in enumerate(plan.types, start=1):
            truth[plan.labels == index] = PLACE_TYPES.index(place)
        topo = TopoMap.from_grid(plan.grid, random_state=seed)
        name = f"generated-{size}-{seed}"
        found.append(labelled_regions(topo.regions, topo.graph, truth, name))
    return found


def score_labels(truth: list[str], predicted: list[str]) -> dict[str, Any]:
    """Per-class precision, recall, F1 and support, macro-F1 over the true classes, and the
    confusion matrix (rows true, columns predicted, in :data:`PLACE_TYPES` order)."""
    classes = [c for c in PLACE_TYPES if c in truth]
    p, r, f, s = precision_recall_fscore_support(truth, predicted, labels=classes, zero_division=0)
    return {
        "per_class": {
            c: {
                "precision": round(float(p[i]), 3),
                "recall": round(float(r[i]), 3),
                "f1": round(float(f[i]), 3),
                "support": int(s[i]),
            }
            for i, c in enumerate(classes)
        },
        "macro_f1": round(float(np.mean(f)), 3),
        "confusion": confusion_matrix(truth, predicted, labels=list(PLACE_TYPES)).tolist(),
    }


def predictions(
    maps: list[dict[str, Any]], more: list[dict[str, Any]] | None = None
) -> dict[str, list[str]]:
    """Per method, the predicted type of every region of ``maps`` (maps in order): the rules,
    a forest trained on all other labelled maps (the other ``maps`` and ``more``, never the map
    it predicts), and "always room"."""
    rules = [label for m in maps for label in rule_classifier(m["features"])]
    forest: list[str] = []
    for held in range(len(maps)):
        train = [m for i, m in enumerate(maps) if i != held] + (more or [])
        forest += train_on_all(train).predict(feature_matrix(maps[held]["features"]))
    count = sum(len(m["truth"]) for m in maps)
    return {"rules": rules, "forest (maps left out)": forest, "always room": ["room"] * count}


def train_on_all(maps: list[dict[str, Any]]) -> ForestClassifier:
    """A :class:`ForestClassifier` trained on every labelled region of ``maps``."""
    x = np.vstack([feature_matrix(m["features"]) for m in maps])
    return ForestClassifier().fit(x, [t for m in maps for t in m["truth"]])


def per_map(maps: list[dict[str, Any]], predicted: dict[str, list[str]]) -> list[dict[str, Any]]:
    """Per map: regions, true corridors, and per method the corridors found, the corridors
    invented and all wrong labels."""
    rows, start = [], 0
    for m in maps:
        truth = m["truth"]
        row: dict[str, Any] = {
            "map": m["map"],
            "regions": len(truth),
            "corridors": truth.count("corridor"),
        }
        for method, labels in predicted.items():
            mine = labels[start : start + len(truth)]
            pairs = list(zip(truth, mine, strict=True))
            row[method] = {
                "corridors found": sum(t == p == "corridor" for t, p in pairs),
                "corridors invented": sum(p == "corridor" != t for t, p in pairs),
                "wrong": sum(t != p for t, p in pairs),
            }
        rows.append(row)
        start += len(truth)
    return rows


def region_records(
    maps: list[dict[str, Any]], predicted: dict[str, list[str]]
) -> list[dict[str, Any]]:
    """One record per region: map, id, true type, every method's prediction and the features."""
    records = []
    rows = [(m, i) for m in maps for i in range(len(m["truth"]))]
    for k, (m, i) in enumerate(rows):
        features = {n: round(float(v[i]), 4) for n, v in m["features"].items() if n != "id"}
        records.append(
            {
                "map": m["map"],
                "id": int(m["features"]["id"][i]),
                "truth": m["truth"][i],
                **{method: labels[k] for method, labels in predicted.items()},
                "features": features,
            }
        )
    return records


def evaluate_labels(
    maps: list[dict[str, Any]], more: list[dict[str, Any]] | None = None
) -> tuple[dict[str, Any], list[dict[str, Any]], list[dict[str, Any]]]:
    """Scores of every method of :func:`predictions` over all regions of ``maps``, keyed by
    method; the :func:`region_records`; the :func:`per_map` counts."""
    truth = [t for m in maps for t in m["truth"]]
    predicted = predictions(maps, more)
    scores = {method: score_labels(truth, labels) for method, labels in predicted.items()}
    return scores, region_records(maps, predicted), per_map(maps, predicted)


#: Colours of the place types in the pictures.
PLACE_COLOURS = {
    "room": "#9ecae1",
    "corridor": "#fdae6b",
    "hall": "#a1d99b",
    "doorway": "#bcbddc",
}


def draw_labels(path: str | Path, labelled: dict[str, Any], predicted: list[str]) -> Path:
    """Write a PNG of one map of :func:`labelled_regions`: every region filled with the colour
    of its predicted type, a text "predicted / true" at its inside point, red where they differ
    (regions without a true type are left white)."""
    from matplotlib.colors import to_rgba
    from matplotlib.patches import Patch

    grid, labels = labelled["regions"].grid, labelled["regions"].labels
    fig, ax = _map_figure(grid)
    ids = labelled["features"]["id"].astype(int)
    table = np.zeros((int(labels.max(initial=0)) + 1, 4))
    for region, place in zip(ids, predicted, strict=True):
        table[region] = to_rgba(PLACE_COLOURS[place], 0.85)
    image = table[labels]
    edges = np.zeros(labels.shape, bool)
    edges[:-1] |= labels[:-1] != labels[1:]
    edges[:, :-1] |= labels[:, :-1] != labels[:, 1:]
    image[edges & (labels > 0)] = (0.2, 0.2, 0.2, 1.0)
    xmin, ymin, xmax, ymax = grid.bounds()
    ax.imshow(image, extent=(xmin, xmax, ymin, ymax), interpolation="nearest")
    for region, place, true in zip(ids, predicted, labelled["truth"], strict=True):
        node = labelled["graph"].nodes[region]
        wrong = place != true
        ax.annotate(
            f"{region}: {place}" + (f" / {true}" if wrong else ""),
            (node["x"], node["y"]),
            fontsize=7 if wrong else 5,
            ha="center",
            color="red" if wrong else "black",
            weight="bold" if wrong else "normal",
        )
    ax.legend(
        handles=[Patch(color=c, label=p) for p, c in PLACE_COLOURS.items()],
        loc="upper right",
        fontsize=7,
    )
    errors = sum(p != t for p, t in zip(predicted, labelled["truth"], strict=True))
    title = f"{labelled['map']}: predicted (red: predicted / true), {errors} of {len(ids)} wrong"
    return _save(fig, ax, path, title)
