"""Classifiers of the feature table: the default rules (thresholds in metres from building
practice) and the trainable random forest, and the check every classifier's output passes.

A classifier is a function of the feature table (:func:`topomap.features.region_features`) or
a fitted scikit-learn estimator (its ``predict`` gets :func:`topomap.features.feature_matrix`).
"""

from __future__ import annotations

import dataclasses
import zipfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from segmentation.base import Estimator
from segmentation.names import SYNONYMS
from topomap.errors import LabelError
from topomap.features import FEATURES, feature_matrix

#: The place types, in table order.
PLACE_TYPES = ("room", "corridor", "hall", "doorway")

Classifier = Callable[[Mapping[str, NDArray[np.float64]]], Sequence[str]] | Any


def _threshold(value: float, lo: float, hi: float, why: str) -> Any:
    """A threshold field: its default, the physically sensible range searched, and why."""
    return dataclasses.field(default=value, metadata={"range": (lo, hi), "why": why})


@dataclasses.dataclass(frozen=True)
class RuleClassifier:
    """The default labels, from thresholds in metres and counts (none fitted to a map):

    - ``doorway``: at most :attr:`doorway_area_m2` and :attr:`doorway_width_m` wide, between
      two regions or more;
    - ``hall``: a large open space: :attr:`hall_area_m2` or more, :attr:`hall_extent_m` or
      more across, :attr:`hall_width_m` or more wide, and mostly floor (:attr:`hall_solidity`
      of its convex hull or more: a ring or an L of corridors is not), and open across, not
      long for its width (slenderness under :attr:`corridor_length`): such a long open space
      is a wide corridor, walked along;
    - ``corridor``: passable but narrow (width from :attr:`corridor_min_width_m` to
      :attr:`corridor_width_m`: narrower strips are laser rays or gaps; and at least
      :attr:`corridor_axis_min_m` wide along most of its medial axis: a strip of floor
      between furniture is narrower than any door) and either long for
      its width (slenderness :attr:`corridor_length` or more) or opening onto
      :attr:`hub_doors` regions or more (a room has one or two entrances), and not a dead
      end behind a door (one neighbour, that leads on to others, through an opening
      narrower than :attr:`corridor_opening_m`: a narrow office or a store room; a corridor
      serves the places off it, or goes on through a wider opening); or walked along
      a corridor-wide medial axis (median width :attr:`corridor_min_width_m` to
      :attr:`corridor_axis_width_m`, ``corridor_axis_m`` :attr:`corridor_length` times
      that, two neighbours or more), though its floor is wide: a corridor with an open area
      or a wide spot joined to it, or with fans of laser rays into the rooms it passes; or
      as narrow and the only way into :attr:`corridor_served_rooms` rooms or more (rooms
      are reached from circulation space); or a passage: narrower than a habitable room
      (:attr:`room_min_width_m`), passed through (two neighbours or more) and
      :attr:`passage_length` times as long as wide;
    - ``room``: everything else;
    - then, when the table has ``"links"``, the corridor system goes on where no door stops
      it: a room as narrow as a corridor (its axis too), passed through (two neighbours or
      more), that opens onto a corridor through an opening of :attr:`corridor_opening_m`
      or more (wider than a single door) is a corridor too, and so is a room as narrow as a
      corridor that opens so onto two corridors, however wide its axis, until no region
      changes. A corridor that the segmentation cut into short pieces is one corridor
      system again.

    Examples
    --------
    >>> table = {
    ...     "area_m2": np.array([40.0, 30.0, 900.0, 3.0]),
    ...     "width_m": np.array([2.0, 5.0, 25.0, 0.4]),
    ...     "slenderness": np.array([10.0, 1.2, 1.4, 19.0]),
    ...     "doors": np.array([4.0, 1.0, 2.0, 1.0]),
    ...     "extent_m": np.array([2.0, 5.0, 30.0, 0.5]),
    ...     "solidity": np.array([1.0, 1.0, 0.9, 0.8]),
    ...     "axis_width_median_m": np.array([2.0, 5.0, 25.0, 0.4]),
    ...     "corridor_axis_m": np.array([36.0, 0.0, 0.0, 0.0]),
    ...     "door_width_max_m": np.array([1.5, 0.9, 2.0, 0.4]),
    ...     "dead_ends": np.array([1.0, 0.0, 0.0, 0.0]),
    ... }
    >>> RuleClassifier()(table)  # a corridor, a room, a hall and a fan of laser rays
    ['corridor', 'room', 'hall', 'room']
    >>> table["width_m"][1] = table["axis_width_median_m"][1] = 3.0  # a 3 m wide piece
    >>> table["doors"][1] = 2.0  # between the corridor and the hall
    >>> table["id"] = np.array([1.0, 2.0, 3.0, 4.0])
    >>> table["links"] = np.array([[1, 2, 2.5], [2, 3, 2.5], [1, 4, 0.4]])
    >>> RuleClassifier()(table)  # no door between it and the corridor: the corridor goes on
    ['corridor', 'corridor', 'hall', 'room']
    >>> wide = {name: column[:1].copy() for name, column in table.items() if name != "links"}
    >>> wide["width_m"][0], wide["slenderness"][0] = 5.5, 3.5  # an open area joined ...
    >>> RuleClassifier()(wide)  # ... to 36 m of a 2 m wide corridor
    ['corridor']
    """

    doorway_area_m2: float = _threshold(3.0, 1.0, 6.0, "a door leaf is 0.8-1.5 m wide")
    doorway_width_m: float = _threshold(1.5, 1.0, 2.5, "wider than a double door is a space")
    corridor_min_width_m: float = _threshold(
        1.2, 0.6, 2.0, "building codes: corridors 1.2 m or wider; narrower is rays or gaps"
    )
    corridor_axis_min_m: float = _threshold(
        0.8, 0.6, 1.0, "the narrowest door: narrower along most of its axis is clutter or rays"
    )
    corridor_width_m: float = _threshold(
        4.0, 2.0, 6.0, "corridors are 1.2-3 m, alcoves and junctions widen the measure"
    )
    corridor_length: float = _threshold(
        4.0, 1.5, 8.0, "a room is rarely over 2.5 times as long as wide; a corridor is walked"
    )
    corridor_axis_width_m: float = _threshold(
        3.0, 2.0, 4.5, "corridors are 1.2-3 m wide along their axis (building practice)"
    )
    hub_doors: float = _threshold(6.0, 3.0, 15.0, "a room has one or two entrances")
    room_min_width_m: float = _threshold(
        2.4, 1.8, 3.0, "building codes: a habitable room is 2.1-2.4 m or more in every direction"
    )
    passage_length: float = _threshold(
        2.5, 1.5, 4.0, "a room is rarely over 2.5 times as long as wide; a passage is walked"
    )
    corridor_served_rooms: float = _threshold(
        3.0, 2.0, 8.0, "rooms are reached from circulation: a room is the only way into few"
    )
    corridor_opening_m: float = _threshold(
        1.2, 0.8, 2.5, "a single door is 0.8-1.2 m: a wider opening is no door"
    )
    hall_area_m2: float = _threshold(150.0, 80.0, 400.0, "beyond any office or flat room")
    hall_extent_m: float = _threshold(8.0, 5.0, 20.0, "open across, not a long strip")
    hall_width_m: float = _threshold(6.0, 3.0, 12.0, "wider than any corridor")
    hall_solidity: float = _threshold(0.5, 0.2, 0.9, "mostly floor, not a ring of corridors")
    #: Rules (:data:`RULES`) switched off, to measure what each does (none by default).
    off: frozenset[str] = frozenset()

    def __post_init__(self) -> None:
        unknown = sorted(set(self.off) - set(RULES))
        if unknown:
            raise LabelError(f"unknown rules {unknown}; known: {', '.join(RULES)}")

    def __call__(self, features: Mapping[str, NDArray[np.float64]]) -> list[str]:
        """The place type of every region of a feature table."""
        f = {name: np.asarray(features[name], float) for name in _RULE_COLUMNS}
        doorway = (
            (f["area_m2"] <= self.doorway_area_m2)
            & (f["width_m"] <= self.doorway_width_m)
            & (f["doors"] >= 2)
        )
        open_space = (
            (f["area_m2"] >= self.hall_area_m2)
            & (f["extent_m"] >= self.hall_extent_m)
            & (f["width_m"] >= self.hall_width_m)
            & (f["solidity"] >= self.hall_solidity)
        )
        long = f["slenderness"] >= self.corridor_length
        none = np.zeros(len(long), bool)
        wide_corridor = open_space & long if "wide corridor" not in self.off else none
        hall = open_space & ~wide_corridor
        narrow = (
            (f["width_m"] >= self.corridor_min_width_m)
            & (f["width_m"] <= self.corridor_width_m)
            & (f["axis_width_median_m"] >= self.corridor_axis_min_m)
        )
        behind_a_door = (
            (f["doors"] == 1)
            & (f["dead_ends"] == 0)
            & (f["door_width_max_m"] < self.corridor_opening_m)
        )
        if "dead end" in self.off:
            behind_a_door = none
        corridor = narrow & ~behind_a_door
        corridor &= long | (f["doors"] >= self.hub_doors)
        if "served rooms" not in self.off:
            corridor |= narrow & (f["dead_ends"] >= self.corridor_served_rooms)
        if "passage" not in self.off:
            corridor |= (
                narrow
                & (f["width_m"] <= self.room_min_width_m)
                & (f["doors"] >= 2)
                & (f["slenderness"] >= self.passage_length)
            )
        if "axis" not in self.off:
            corridor |= self._along_axis(f)
        corridor |= wide_corridor
        labels = np.select([doorway, hall, corridor], ["doorway", "hall", "corridor"], "room")
        if "links" in features and "second pass" not in self.off:
            axis_narrow = f["axis_width_median_m"] <= self.corridor_axis_width_m
            passed = narrow & axis_narrow & (f["doors"] >= 2)
            bridges = narrow if "bridge" not in self.off else none
            labels = self._continue_corridors(labels, passed, bridges, features)
        return [str(label) for label in labels]

    def _along_axis(self, f: Mapping[str, NDArray[np.float64]]) -> NDArray[np.bool_]:
        """The regions walked along a corridor-wide medial axis: the axis is mostly
        :attr:`corridor_min_width_m` to :attr:`corridor_axis_width_m` wide (median) and
        :attr:`corridor_length` times as long (``corridor_axis_m``) as that, passed through
        (two neighbours or more). A corridor with a wide spot or an open area joined to it, or
        with fans of rays into the rooms it passes, is one, though its floor is wide."""
        axis = f["axis_width_median_m"]
        return (
            (axis >= self.corridor_min_width_m)
            & (axis <= self.corridor_axis_width_m)
            & (f["corridor_axis_m"] >= self.corridor_length * axis)
            & (f["doors"] >= 2)
        )

    def _continue_corridors(
        self,
        labels: NDArray[np.str_],
        passed: NDArray[np.bool_],
        bridges: NDArray[np.bool_],
        features: Mapping[str, NDArray[np.float64]],
    ) -> NDArray[np.str_]:
        """``labels`` with the rooms of ``passed`` that open onto a corridor through an
        opening of :attr:`corridor_opening_m` or more made corridors, until none changes."""
        ids = np.asarray(features["id"], float)
        links = np.asarray(features["links"], float).reshape(-1, 3)
        links = links[links[:, 2] >= self.corridor_opening_m]
        where = {region: i for i, region in enumerate(ids.tolist())}
        pairs = [(where[a], where[b]) for a, b, _ in links.tolist() if a in where and b in where]
        ends = np.asarray(pairs, int).reshape(-1, 2)
        ends = np.vstack([ends, ends[:, ::-1]])  # both directions
        labels = labels.copy()
        while True:
            onto = (labels[ends[:, 0]] == "room") & (labels[ends[:, 1]] == "corridor")
            joins = np.zeros(len(labels), bool)
            joins[ends[onto & passed[ends[:, 0]], 0]] = True
            # a corridor-wide room between two corridors, no door on either side: whatever
            # its axis (fans of rays into the rooms beside widen it), the corridor goes on
            pieces = {(a, b) for a, b in ends[onto & bridges[ends[:, 0]]].tolist()}
            joins |= np.bincount([a for a, _ in pieces], minlength=len(labels)) >= 2
            if not joins.any():
                return labels
            labels[joins] = "corridor"

    @classmethod
    def thresholds(cls) -> dict[str, tuple[float, tuple[float, float], str]]:
        """Name -> (default, searched range, why) of every threshold."""
        return {
            f.name: (float(f.default), f.metadata["range"], f.metadata["why"])  # type: ignore[arg-type]
            for f in dataclasses.fields(cls)
            if "range" in f.metadata
        }


#: The rules beyond the thresholds' first cut, by name (``RuleClassifier(off=...)`` switches
#: them off): what each says.
RULES = {
    "dead end": "a slender room behind a single door, leading on to others, is a room",
    "axis": "walked along a corridor-wide medial axis, however wide its floor: a corridor",
    "served rooms": "as narrow as a corridor and the only way into 3 rooms or more: a corridor",
    "passage": "narrower than a room, passed through, 2.5 times as long as wide: a corridor",
    "wide corridor": "hall-sized but long for its width: a wide corridor, not a hall",
    "second pass": "a corridor-narrow room opening onto a corridor wider than a door: corridor",
    "bridge": "a corridor-narrow room open to two corridors, whatever its axis: corridor",
}
#: The feature columns the rules read.
_RULE_COLUMNS = (
    "area_m2",
    "width_m",
    "slenderness",
    "doors",
    "extent_m",
    "solidity",
    "axis_width_median_m",
    "corridor_axis_m",
    "door_width_max_m",
    "dead_ends",
)
#: The default classifier.
rule_classifier = RuleClassifier()


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
    if classifier is None:
        return _checked(rule_classifier, rule_classifier(features), features)
    name = getattr(classifier, "__name__", type(classifier).__name__)
    if not (hasattr(classifier, "predict") or callable(classifier)):
        raise LabelError(f"classifier {name} is neither callable nor has predict()")
    try:
        if hasattr(classifier, "predict"):
            found = classifier.predict(feature_matrix(features))
        else:
            found = classifier(features)
        found = [str(label) for label in found]
    except Exception as err:  # the user's classifier, whatever it raised or returned
        raise LabelError(
            f"classifier {name} failed ({type(err).__name__}: {err}); it returns one place "
            "type per region"
        ) from err
    return _checked(classifier, found, features)


def _checked(
    classifier: Classifier, found: Sequence[str], features: Mapping[str, NDArray[np.float64]]
) -> list[str]:
    """``found`` as known place types, one per region (synonyms read as their type)."""
    name = getattr(classifier, "__name__", type(classifier).__name__)
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


#: The only type a saved forest may hold beyond skops' default-trusted ones.
_FOREST_TYPES = ("sklearn.tree._tree.Tree",)


class ForestClassifier(Estimator):
    """A class-balanced random forest on the feature matrix, trained on labelled regions.

    A scikit-learn estimator (``get_params``, ``set_params``, :func:`sklearn.base.clone`).
    Saved with skops (:meth:`save`, :meth:`load`), never pickled: loading builds only the
    types a forest is made of and refuses a file that holds any other.

    Parameters
    ----------
    n_estimators, min_samples_leaf, random_state
        Forest size, smallest leaf and seed.

    Attributes
    ----------
    forest_ : sklearn.ensemble.RandomForestClassifier
        The fitted forest.
    classes_ : list of str
        The place types seen in training.
    """

    def __init__(
        self, n_estimators: int = 200, min_samples_leaf: int = 1, random_state: int = 0
    ) -> None:
        self.n_estimators = n_estimators
        self.min_samples_leaf = min_samples_leaf
        self.random_state = random_state

    def _validate_params(self) -> None:
        for name in ("n_estimators", "min_samples_leaf"):
            value = getattr(self, name)
            if not (isinstance(value, int | np.integer) and value >= 1):
                raise LabelError(f"{name} must be an integer >= 1, got {value!r}")

    def fit(self, features: NDArray[np.float64], labels: Sequence[str]) -> ForestClassifier:
        """Learn from a feature matrix (:func:`~topomap.features.feature_matrix`) and one place
        type per row."""
        self._validate_params()
        features = np.asarray(features, float)
        if features.ndim != 2 or features.shape[1] != len(FEATURES):
            raise LabelError(f"expected a matrix of {len(FEATURES)} feature columns")
        if len(labels) != len(features):
            raise LabelError(f"{len(labels)} labels for {len(features)} rows")
        from sklearn.ensemble import RandomForestClassifier  # only a learned model needs it

        forest = RandomForestClassifier(
            self.n_estimators,
            min_samples_leaf=self.min_samples_leaf,
            class_weight="balanced",
            random_state=self.random_state,
        ).fit(features, [str(label) for label in labels])
        self._set_fitted(forest)
        return self

    def _set_fitted(self, forest: Any) -> None:
        self.forest_ = forest
        self.classes_ = [str(label) for label in forest.classes_]

    def predict(self, features: NDArray[np.float64]) -> list[str]:
        """Place type of each row."""
        if not hasattr(self, "forest_"):
            raise LabelError("ForestClassifier is not fitted")
        return [str(label) for label in self.forest_.predict(np.asarray(features, float))]

    def save(self, path: str | Path) -> Path:
        """Write the fitted forest and the feature names as a skops file."""
        import skops.io

        if not hasattr(self, "forest_"):
            raise LabelError("ForestClassifier is not fitted: nothing to save")
        path = Path(path)
        skops.io.dump(
            {"format": "topomap-forest-2", "features": list(FEATURES), "forest": self.forest_}, path
        )
        return path

    @classmethod
    def load(cls, path: str | Path) -> ForestClassifier:
        """Read a file written by :meth:`save`.

        Raises
        ------
        LabelError
            Naming the file: not a skops file, another format, other features, or types
            that a forest is not made of (never built).
        """
        import skops.io

        path = Path(path)
        try:
            untrusted = skops.io.get_untrusted_types(file=path)
            strange = sorted(set(untrusted) - set(_FOREST_TYPES))
            if strange:
                raise LabelError(f"{path}: holds types a forest is not made of: {strange}")
            data = skops.io.load(path, trusted=list(untrusted))
        except LabelError:
            raise
        except (OSError, ValueError, KeyError, TypeError, zipfile.BadZipFile) as err:
            raise LabelError(f"{path}: not a topomap forest file ({err})") from err
        if not isinstance(data, dict) or data.get("format") != "topomap-forest-2":
            raise LabelError(f"{path}: not a topomap forest file (no topomap-forest-2 format)")
        if data.get("features") != list(FEATURES):
            raise LabelError(f"{path}: features {data.get('features')} are not {list(FEATURES)}")
        forest = data["forest"]
        model = cls(forest.n_estimators, forest.min_samples_leaf, forest.random_state)
        model._set_fitted(forest)
        return model
