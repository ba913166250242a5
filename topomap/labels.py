"""Region labels (room, corridor, hall, doorway) and human names ("corridor 2", "hall 1").

A classifier is anything that maps the region features of :func:`region_features` to place
types: a plain function of the feature table, or a fitted scikit-learn estimator (its
``predict`` gets the feature matrix in :data:`FEATURES` order). :func:`rule_classifier` is
the default and needs no training; :class:`ForestClassifier` learns from labelled maps.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import cv2
import networkx as nx
import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from skimage.measure import perimeter
from skimage.morphology import disk, skeletonize

from segmentation.conditioning import clearance_of
from segmentation.regions import Regions
from topomap.errors import LabelError

#: The place types, in table order.
PLACE_TYPES = ("room", "corridor", "hall", "doorway")
#: Other words for a place type, accepted in names and queries ("aisle 2" is "corridor 2").
SYNONYMS = {"aisle": "corridor", "hallway": "corridor", "door": "doorway"}
#: Region features, in the column order given to estimators.
FEATURES = (
    "area_m2",
    "width_m",
    "slenderness",
    "compactness",
    "elongation",
    "doors",
    "door_width_max_m",
    "door_width_mean_m",
    "perimeter_m",
    "skeleton_length_m",
    "skeleton_width_m",
    "skeleton_slenderness",
    "branch_points",
    "betweenness",
    "door_span_m",
)
#: Furniture holes up to this size (m^2) are filled before measuring shape.
FURNITURE_HOLE_M2 = 4.0
#: The medial axis is traced on cells of about this size (m), coarser cells being given as is.
SKELETON_CELL_M = 0.1
#: Notches (furniture against a wall) narrower than twice this (m) are closed, too.
FURNITURE_GAP_M = 0.5

Classifier = Callable[[Mapping[str, NDArray[np.float64]]], Sequence[str]] | Any


def region_features(regions: Regions, graph: nx.Graph) -> dict[str, NDArray[np.float64]]:
    """Shape and connectivity features of every region, as columns (one value per region,
    regions in ascending id order; ``"id"`` holds the ids).

    ``width_m`` is twice the 95th percentile of the distance to the region's edge; shape
    features are measured after filling furniture holes up to :data:`FURNITURE_HOLE_M2` and
    closing notches narrower than twice :data:`FURNITURE_GAP_M` (furniture along walls):
    ``slenderness`` = area / width^2, ``compactness`` = 4 pi area / perimeter^2,
    ``elongation`` = long / short side of the minimum-area rectangle. ``doors`` is the
    region's degree in the graph, door widths those of its graph edges.
    """
    res = regions.grid.resolution
    ids = sorted(int(n) for n in graph.nodes)
    between = nx.betweenness_centrality(graph) if len(graph) > 2 else {}
    boxes = ndimage.find_objects(regions.labels)
    columns: dict[str, list[float]] = {name: [] for name in ("id", *FEATURES)}
    for region in ids:
        box = boxes[region - 1]
        gap = max(1, round(FURNITURE_GAP_M / res))
        mask = np.pad(regions.labels[box] == region, 2 * gap + 1)
        filled = _fill_small_holes(mask, int(FURNITURE_HOLE_M2 / res**2))
        kernel = disk(gap).astype(np.uint8)
        filled = cv2.morphologyEx(filled.astype(np.uint8), cv2.MORPH_CLOSE, kernel).astype(bool)
        area = float(filled.sum()) * res**2
        distance = clearance_of(filled, 1.0).astype(np.float64)  # cells; the mask is padded
        depth = distance[filled] * res
        width = 2 * float(np.percentile(depth, 95))
        step = max(1, int(SKELETON_CELL_M / res))
        length, mean_width, branches = skeleton_shape(
            filled[::step, ::step], distance[::step, ::step] / step, res * step
        )
        edge = float(perimeter(filled)) * res
        outline, _ = cv2.findContours(
            filled.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE
        )
        (_, _), (w, h), _ = cv2.minAreaRect(np.vstack(outline))
        widths = [float(d) for _, _, d in graph.edges(region, data="width")]
        doors = [door.centre for _, _, ds in graph.edges(region, data="doors") for door in ds]
        values = {
            "id": region,
            "area_m2": area,
            "width_m": width,
            "slenderness": area / width**2 if width else 0.0,
            "compactness": 4 * math.pi * area / edge**2 if edge else 1.0,
            "elongation": max(w, h) / max(min(w, h), 1.0),
            "doors": float(graph.degree(region)),
            "door_width_max_m": max(widths, default=0.0),
            "door_width_mean_m": float(np.mean(widths)) if widths else 0.0,
            "perimeter_m": edge,
            "skeleton_length_m": length,
            "skeleton_width_m": mean_width,
            "skeleton_slenderness": length / mean_width if mean_width else 0.0,
            "branch_points": float(branches),
            "betweenness": float(between.get(region, 0.0)),
            "door_span_m": _span(np.asarray(doors, float).reshape(-1, 2)),
        }
        for name, value in values.items():
            columns[name].append(value)
    return {name: np.asarray(values, float) for name, values in columns.items()}


def skeleton_shape(
    mask: NDArray[np.bool_], distance: NDArray[np.float64], resolution: float
) -> tuple[float, float, int]:
    """``(length m, mean width m, branch points)`` of the medial axis of ``mask``.

    The axis is :func:`skimage.morphology.skeletonize` with its spurs cut: a piece between an
    end and a branch point shorter than the space is wide at that branch point (twice
    ``distance`` there, ``distance`` being the distance to the edge in cells) is a corner or a
    notch, not a way through. The length counts axis cells (a straight axis of n cells is n
    cells long), the width is twice the mean ``distance`` along the axis, and branch points are
    the clusters of axis cells with three or more axis neighbours. A ``w`` x ``l`` rectangle
    (``w < l``) has an axis about ``l - w`` long and ``w`` wide, with no branch point.

    Examples
    --------
    >>> mask = np.zeros((60, 220), bool)
    >>> mask[10:50, 10:210] = True  # 10 x 2 m at 5 cm
    >>> length, width, branches = skeleton_shape(mask, ndimage.distance_transform_edt(mask), 0.05)
    >>> round(length), round(width), branches
    (8, 2, 0)
    """
    axis = skeletonize(mask)
    for _ in range(2):  # cutting spurs can leave a new, shorter one at a former branch point
        neighbours = (
            ndimage.convolve(axis.astype(np.uint8), np.ones((3, 3), np.uint8), mode="constant") - 1
        )
        junctions = axis & (neighbours >= 3)
        near = ndimage.binary_dilation(junctions, np.ones((3, 3), bool))
        pieces, count = ndimage.label(axis & ~near, np.ones((3, 3), bool))
        if count == 0 or not junctions.any():
            break
        ends = axis & (neighbours == 1)
        sizes = np.bincount(pieces.ravel(), minlength=count + 1)
        has_end = np.bincount(pieces[ends], minlength=count + 1) > 0
        # the width where each piece meets the rest: the largest distance along the piece
        reach = np.zeros(count + 1)
        np.maximum.at(reach, pieces[axis], distance[axis])
        spur = has_end & (sizes < 2 * reach) & (np.arange(count + 1) > 0)
        if not spur.any():
            break
        axis = axis & ~spur[pieces]
    if not axis.any():
        return 0.0, 2 * float(distance.max()) * resolution, 0
    neighbours = (
        ndimage.convolve(axis.astype(np.uint8), np.ones((3, 3), np.uint8), mode="constant") - 1
    )
    _, branches = ndimage.label(axis & (neighbours >= 3), np.ones((3, 3), bool))
    length = float(axis.sum()) * resolution
    return length, 2 * float(distance[axis].mean()) * resolution, int(branches)


def _span(points: NDArray[np.float64]) -> float:
    """The largest distance between two of ``points`` (0 for fewer than two)."""
    if len(points) < 2:
        return 0.0
    return float(np.max(np.linalg.norm(points[:, None] - points[None], axis=2)))


def _fill_small_holes(mask: NDArray[np.bool_], most: int) -> NDArray[np.bool_]:
    """``mask`` with its enclosed holes of at most ``most`` cells filled."""
    holes, _ = ndimage.label(ndimage.binary_fill_holes(mask) & ~mask)
    sizes = np.bincount(holes.ravel())
    small = (sizes <= most) & (np.arange(len(sizes)) > 0)
    return mask | small[holes]


def feature_matrix(features: Mapping[str, NDArray[np.float64]]) -> NDArray[np.float64]:
    """The feature columns as an ``(n_regions, len(FEATURES))`` matrix."""
    return np.column_stack([features[name] for name in FEATURES])


#: A space with this many doors or more, under :data:`HUB_MAX_M2`, is a circulation space.
HUB_DOORS = 5
#: Above this area (m^2) many doors no longer say corridor (open-plan rooms, halls).
HUB_MAX_M2 = 100.0
#: A space at most this wide (m) with doors at least :data:`PASSAGE_SPAN` widths apart is a
#: corridor: a passage, too narrow to furnish as a room and walked from end to end.
PASSAGE_WIDTH_M = 2.5
PASSAGE_SPAN = 2.0


def rule_classifier(features: Mapping[str, NDArray[np.float64]]) -> list[str]:
    """The default labels, from thresholds in metres and counts, none fitted to a map.

    - ``doorway``: a small region (under 3 m^2, at most 1.5 m wide) between two or more others;
    - ``corridor``, any of
      - long for its width: at most 3.5 m wide with slenderness 3.5 or more and three doors or
        more, or slenderness 8 or more whatever its doors; or a large space (150 m^2 or more)
        of slenderness 4 or more, a wide corridor;
      - a hub: :data:`HUB_DOORS` doors or more on under :data:`HUB_MAX_M2` (a room has one or
        two entrances; a small space that many others open onto is where people pass, even
        when the segmentation cut it short);
      - a passage: at most :data:`PASSAGE_WIDTH_M` wide (narrower than a furnished room) with
        two doors at least :data:`PASSAGE_SPAN` widths apart (walked from end to end);
    - ``hall``: any other space of 150 m^2 or more at least 8 m wide;
    - ``room``: everything else.

    Examples
    --------
    >>> features = {
    ...     "area_m2": np.array([40.0, 30.0, 300.0]),
    ...     "width_m": np.array([2.0, 5.0, 15.0]),
    ...     "slenderness": np.array([10.0, 1.2, 1.3]),
    ...     "doors": np.array([4.0, 1.0, 2.0]),
    ...     "door_span_m": np.array([18.0, 0.0, 12.0]),
    ... }
    >>> rule_classifier(features)
    ['corridor', 'room', 'hall']
    """
    labels = []
    for i in range(len(features["area_m2"])):
        area, width = features["area_m2"][i], features["width_m"][i]
        slender, doors = features["slenderness"][i], features["doors"][i]
        long = (width <= 3.5 and ((slender >= 3.5 and doors >= 3) or slender >= 8.0)) or (
            area >= 150.0 and slender >= 4.0
        )
        hub = doors >= HUB_DOORS and area < HUB_MAX_M2
        span = features["door_span_m"][i]
        passage = width <= PASSAGE_WIDTH_M and doors >= 2 and span >= PASSAGE_SPAN * width
        if area < 3.0 and width <= 1.5 and doors >= 2:
            labels.append("doorway")
        elif long or hub or passage:
            labels.append("corridor")
        elif area >= 150.0 and width >= 8.0:
            labels.append("hall")
        else:
            labels.append("room")
    return labels


def classify(
    classifier: Classifier | None, features: Mapping[str, NDArray[np.float64]]
) -> list[str]:
    """Run a classifier (a function of the features, or an estimator with ``predict``) and
    check its output: one known place type (or synonym) per region.

    Raises
    ------
    LabelError
        Naming the classifier, when it returns the wrong number of labels or an unknown one.
    """
    classifier = rule_classifier if classifier is None else classifier
    name = getattr(classifier, "__name__", type(classifier).__name__)
    if hasattr(classifier, "predict"):
        found = classifier.predict(feature_matrix(features))
    elif callable(classifier):
        found = classifier(features)
    else:
        raise LabelError(f"classifier {name} is neither callable nor has predict()")
    found = [str(label).strip().lower() for label in found]
    count = len(features["id"])
    if len(found) != count:
        raise LabelError(f"classifier {name} returned {len(found)} labels for {count} regions")
    labels = [SYNONYMS.get(label, label) for label in found]
    unknown = sorted({label for label in labels if label not in PLACE_TYPES})
    if unknown:
        raise LabelError(
            f"classifier {name} returned unknown labels {unknown}; known: {', '.join(PLACE_TYPES)}"
        )
    return labels


def name_regions(graph: nx.Graph, labels: Mapping[int, str]) -> dict[int, str]:
    """Unique names "<label> <n>", numbered per label in reading order (top to bottom, then
    left to right, by each region's inside point)."""
    names = {}
    for place in PLACE_TYPES:
        members = [r for r, label in labels.items() if label == place]
        members.sort(key=lambda r: (-round(graph.nodes[r]["y"], 1), graph.nodes[r]["x"]))
        names.update({r: f"{place} {n}" for n, r in enumerate(members, start=1)})
    return names


def label_graph(
    regions: Regions, graph: nx.Graph, classifier: Classifier | None = None
) -> dict[int, str]:
    """Label every region of ``graph`` with a place type (``classifier``, the rules by default)
    and a unique name, stored as the nodes' ``label`` and ``name``; returns id -> label."""
    features = region_features(regions, graph)
    found = classify(classifier, features)
    labels = dict(zip(features["id"].astype(int).tolist(), found, strict=True))
    names = name_regions(graph, labels)
    for region in graph.nodes:
        graph.nodes[region]["label"] = labels[region]
        graph.nodes[region]["name"] = names[region]
    return labels


def normalise_name(text: str) -> str:
    """A name as stored: lower case, single spaces, a synonym's first word replaced."""
    words = re.sub(r"\s+", " ", text.strip().lower()).split(" ")
    words[0] = SYNONYMS.get(words[0], words[0])
    return " ".join(words)


def find_region(graph: nx.Graph, query: int | str) -> int:
    """The region id of ``query``: an id, or a name ("hall 1", "Aisle 2"; case-insensitive).

    Raises
    ------
    LabelError
        No such region; the message lists the known names.
    """
    if not isinstance(query, str) or query.strip().isdigit():
        region = int(query)
        if region in graph:
            return region
        raise LabelError(f"no region {region}; ids: {sorted(graph.nodes)}")
    wanted = normalise_name(query)
    for region, name in graph.nodes(data="name"):
        if name is not None and normalise_name(str(name)) == wanted:
            return int(region)
    known = sorted(str(n) for _, n in graph.nodes(data="name") if n is not None)
    raise LabelError(f"no region named {query!r}; known names: {', '.join(known) or 'none'}")


def rename(graph: nx.Graph, old: int | str, new: str) -> None:
    """Give a region (by id or name) a new name; a name already taken is refused and nothing
    changes."""
    region = find_region(graph, old)
    wanted = normalise_name(new)
    if not wanted:
        raise LabelError("a region name cannot be empty")
    if wanted.isdigit():
        raise LabelError(f"a region name cannot be only digits ({new!r} reads as a region id)")
    for other, name in graph.nodes(data="name"):
        if other != region and name is not None and normalise_name(str(name)) == wanted:
            raise LabelError(f"the name {new!r} is taken by region {other}")
    graph.nodes[region]["name"] = new.strip()


class ForestClassifier:
    """A class-balanced random forest on the region features, trained on labelled regions.

    Saved as JSON (the training table and the settings), never pickled: :meth:`load` refits
    the same forest from them (same data, seed and scikit-learn version give the same trees).

    Parameters
    ----------
    n_estimators, random_state
        Forest size and seed.
    """

    def __init__(self, n_estimators: int = 200, random_state: int = 0) -> None:
        self.n_estimators, self.random_state = n_estimators, random_state
        self._x = np.zeros((0, len(FEATURES)))
        self._y: list[str] = []
        self._forest: Any = None

    def fit(self, features: NDArray[np.float64], labels: Sequence[str]) -> ForestClassifier:
        """Learn from a feature matrix (:func:`feature_matrix`) and one place type per row."""
        features = np.asarray(features, float)
        if features.ndim != 2 or features.shape[1] != len(FEATURES):
            raise LabelError(f"expected a matrix of {len(FEATURES)} feature columns")
        if len(labels) != len(features):
            raise LabelError(f"{len(labels)} labels for {len(features)} rows")
        self._x, self._y = features, [str(label) for label in labels]
        from sklearn.ensemble import RandomForestClassifier  # only a learned model needs it

        self._forest = RandomForestClassifier(
            self.n_estimators, class_weight="balanced", random_state=self.random_state
        ).fit(self._x, self._y)
        return self

    def predict(self, features: NDArray[np.float64]) -> list[str]:
        """Place type of each row."""
        if self._forest is None:
            raise LabelError("ForestClassifier is not fitted")
        return [str(label) for label in self._forest.predict(np.asarray(features, float))]

    def save(self, path: str | Path) -> Path:
        """Write the training table and settings as JSON."""
        path = Path(path)
        path.write_text(
            json.dumps(
                {
                    "format": "topomap-forest-1",
                    "features": list(FEATURES),
                    "n_estimators": self.n_estimators,
                    "random_state": self.random_state,
                    "x": self._x.tolist(),
                    "y": self._y,
                }
            )
        )
        return path

    @classmethod
    def load(cls, path: str | Path) -> ForestClassifier:
        """Read a file written by :meth:`save` and refit the forest."""
        path = Path(path)
        try:
            data = json.loads(path.read_text())
            model = cls(int(data["n_estimators"]), int(data["random_state"]))
            if data.get("features") != list(FEATURES):
                raise LabelError(f"{path}: features {data.get('features')} are not {FEATURES}")
            return model.fit(np.asarray(data["x"], float), data["y"])
        except (KeyError, TypeError, json.JSONDecodeError) as err:
            raise LabelError(f"{path}: not a topomap forest file ({err})") from err
