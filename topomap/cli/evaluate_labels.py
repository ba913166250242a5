"""Evaluation of region labels on labelled buildings (:mod:`topomap.cli.label_sources`), with
whole buildings left out.

Methods: the default rules (:class:`~topomap.classifiers.RuleClassifier`, thresholds from
building practice, nothing fitted), the rules with their thresholds searched on the other
buildings, a random forest trained on the other buildings, and "always room". For every
building, whatever a method learns it learns from the other buildings only (leave one
building out, LOBO); in-sample, it learns from all. Scores are per region, per source.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from sklearn.metrics import confusion_matrix, precision_recall_fscore_support

from maps.grid import clearance_of
from topomap.classifiers import (
    PLACE_TYPES,
    RULES,
    ForestClassifier,
    RuleClassifier,
    rule_classifier,
)
from topomap.cli.drawing import _map_figure, _save
from topomap.cli.label_sources import LabelledMap
from topomap.features import FEATURES, feature_matrix

#: A method: trained on some maps, it returns a classifier of a feature table.
Method = Callable[[Sequence[LabelledMap]], Callable[[LabelledMap], list[str]]]
#: Sources that are another view of a source's maps (scored apart, not pooled in "all").
VIEWS = ("rose2-rooms",)
#: Values tried per threshold, across its physically sensible range.
STEPS = 21


def score_labels(truth: Sequence[str], predicted: Sequence[str]) -> dict[str, Any]:
    """Per-class precision, recall, F1 and support, macro-F1 over the true classes, and the
    confusion matrix (rows true, columns predicted, in :data:`PLACE_TYPES` order).

    Examples
    --------
    >>> score_labels(["room", "corridor"], ["room", "room"])["macro_f1"]
    0.333
    """
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
        "macro_f1": round(float(np.mean(f)), 3) if classes else 0.0,
        "confusion": confusion_matrix(truth, predicted, labels=list(PLACE_TYPES)).tolist(),
    }


def _macro_f1(truth: Sequence[str], predicted: Sequence[str]) -> float:
    """Macro-F1 over the true classes, as :func:`score_labels` (unrounded; numpy, for the
    many calls of the threshold search)."""
    t, p = np.asarray(truth), np.asarray(predicted)
    scores = []
    for c in PLACE_TYPES:
        if (t == c).any():
            hits = float(((t == c) & (p == c)).sum())
            scores.append(2 * hits / ((t == c).sum() + (p == c).sum()))
    return float(np.mean(scores)) if scores else 0.0


def _rules(classifier: RuleClassifier) -> Callable[[LabelledMap], list[str]]:
    return lambda m: classifier(m.features)


def fit_thresholds(
    maps: Sequence[LabelledMap], start: RuleClassifier | None = None
) -> RuleClassifier:
    """The rules with each threshold searched, one at a time (two rounds), over its range
    (:meth:`RuleClassifier.thresholds`) for the best macro-F1 on ``maps``; ties keep the value
    nearest the current one."""
    rules = start or RuleClassifier()
    truth = [t for m in maps for t in m.truth]
    for _ in range(2):
        for name, (_, (lo, hi), _) in RuleClassifier.thresholds().items():
            current = getattr(rules, name)
            best = max(
                np.linspace(lo, hi, STEPS),
                key=lambda v: (
                    round(
                        _macro_f1(
                            truth, _predict(rules.__class__(**{**vars(rules), name: v}), maps)
                        ),
                        6,
                    ),
                    -abs(v - current),
                ),
            )
            rules = rules.__class__(**{**vars(rules), name: float(best)})
    return rules


def choose_rules(
    maps: Sequence[LabelledMap], start: RuleClassifier | None = None
) -> RuleClassifier:
    """The rules with each of :data:`~topomap.classifiers.RULES` kept or switched off, one at a
    time, by macro-F1 on ``maps``: a rule goes only where it lowers the score (a tie keeps
    it: its reason is building practice, and it changes nothing on these maps)."""
    rules = start or RuleClassifier()
    truth = [t for m in maps for t in m.truth]
    for name in RULES:
        without = dataclasses.replace(rules, off=rules.off | {name})
        if _macro_f1(truth, _predict(without, maps)) > _macro_f1(truth, _predict(rules, maps)):
            rules = without
    return rules


def rule_changes(maps: Sequence[LabelledMap], rules: RuleClassifier) -> list[dict[str, Any]]:
    """Per rule of :data:`~topomap.classifiers.RULES`: the regions it changes (the :data:`VIEWS`
    left out), how many it gets right that are wrong without it and the reverse, and the
    buildings they are in (a rule that fixes one building is that building's rule)."""
    maps = [m for m in maps if m.source not in VIEWS]
    rows = []
    for name in RULES:
        without = dataclasses.replace(rules, off=rules.off | {name})
        fixed, broken, buildings = 0, 0, set()
        for m in maps:
            for t, a, b in zip(m.truth, rules(m.features), without(m.features), strict=True):
                if a != b:
                    fixed += t == a
                    broken += t == b
                    buildings.add(m.building)
        rows.append(
            {
                "rule": name,
                "right with it only": fixed,
                "right without it only": broken,
                "buildings": ", ".join(sorted(buildings)) or "-",
                "what": RULES[name],
            }
        )
    return rows


def _predict(rules: RuleClassifier, maps: Sequence[LabelledMap]) -> list[str]:
    return [label for m in maps for label in rules(m.features)]


def train_forest(maps: Sequence[LabelledMap]) -> ForestClassifier:
    """A :class:`ForestClassifier` trained on every labelled region of ``maps``."""
    x = np.vstack([feature_matrix(m.features) for m in maps])
    return ForestClassifier().fit(x, [t for m in maps for t in m.truth])


def _forest(maps: Sequence[LabelledMap]) -> Callable[[LabelledMap], list[str]]:
    model = train_forest(maps)
    return lambda m: model.predict(feature_matrix(m.features))


#: The methods compared, by name.
METHODS: dict[str, Method] = {
    "rules": lambda maps: _rules(rule_classifier),
    "rules, each rule chosen": lambda maps: _rules(choose_rules(maps)),
    "rules, thresholds searched": lambda maps: _rules(fit_thresholds(maps)),
    "forest": _forest,
    "always room": lambda maps: lambda m: ["room"] * len(m.truth),
}


def predict(maps: Sequence[LabelledMap], method: Method, *, held_out: bool) -> list[list[str]]:
    """Per map, the labels of ``method``: trained on every other building's maps
    (``held_out``, leave one building out) or on all maps (in-sample); never on the
    :data:`VIEWS` (people's rooms as regions have no doors between them)."""
    usable = [m for m in maps if m.source not in VIEWS]
    if not held_out:
        classifier = method(usable)
        return [classifier(m) for m in maps]
    found: dict[int, list[str]] = {}
    for building in sorted({m.building for m in maps}):
        train = [m for m in usable if m.building != building]
        classifier = method(train)
        for i, m in enumerate(maps):
            if m.building == building:
                found[i] = classifier(m)
    return [found[i] for i in range(len(maps))]


def evaluate(maps: Sequence[LabelledMap]) -> dict[str, Any]:
    """Per method, in-sample and LOBO, the labels of every map and the scores per source
    and over all sources but the :data:`VIEWS` (``"all"``)."""
    sources = sorted({m.source for m in maps})
    result: dict[str, Any] = {}
    for name, method in METHODS.items():
        for mode in ("in-sample", "LOBO"):
            labels = predict(maps, method, held_out=mode == "LOBO")
            scores = {}
            for source in [*sources, "all"]:
                chosen = [
                    i
                    for i, m in enumerate(maps)
                    if m.source == source or (source == "all" and m.source not in VIEWS)
                ]
                truth = [t for i in chosen for t in maps[i].truth]
                scores[source] = score_labels(truth, [p for i in chosen for p in labels[i]])
            result[f"{name} ({mode})"] = {"labels": labels, "scores": scores}
    return result


def margins(maps: Sequence[LabelledMap], rules: RuleClassifier) -> dict[str, dict[str, Any]]:
    """How far each threshold of ``rules`` can move, the others fixed, before macro-F1 on
    ``maps`` (the :data:`VIEWS` left out) drops by more than 0.01: the lowest and highest
    value of the searched range (:data:`STEPS` values) that keep it, and the score."""
    maps = [m for m in maps if m.source not in VIEWS]
    truth = [t for m in maps for t in m.truth]
    base = _macro_f1(truth, _predict(rules, maps))
    found = {}
    for name, (_, (lo, hi), _) in RuleClassifier.thresholds().items():
        value = getattr(rules, name)
        values = np.union1d(np.linspace(lo, hi, STEPS), [value])
        held = [
            _macro_f1(truth, _predict(rules.__class__(**{**vars(rules), name: v}), maps))
            >= base - 0.01
            for v in values
        ]
        at = int(np.searchsorted(values, value))
        low = at
        while low > 0 and held[low - 1]:
            low -= 1
        high = at
        while high < len(values) - 1 and held[high + 1]:
            high += 1
        found[name] = {
            "value": round(float(value), 3),
            "lowest": round(float(values[low]), 3),
            "highest": round(float(values[high]), 3),
            "range": [lo, hi],
            "macro_f1": round(base, 3),
        }
    return found


def mistakes(maps: Sequence[LabelledMap], labels: Sequence[list[str]]) -> list[dict[str, Any]]:
    """Per map: regions, corridors found and invented, wrong labels, corridors called rooms
    and halls called corridors."""
    rows = []
    for m, mine in zip(maps, labels, strict=True):
        pairs = list(zip(m.truth, mine, strict=True))
        rows.append(
            {
                "source": m.source,
                "map": m.map,
                "regions": len(pairs),
                "corridors": m.truth.count("corridor"),
                "found": sum(t == p == "corridor" for t, p in pairs),
                "invented": sum(p == "corridor" != t for t, p in pairs),
                "wrong": sum(t != p for t, p in pairs),
                "corridor as room": sum(t == "corridor" and p == "room" for t, p in pairs),
                "hall as corridor": sum(t == "hall" and p == "corridor" for t, p in pairs),
            }
        )
    return rows


def region_records(maps: Sequence[LabelledMap], result: dict[str, Any]) -> list[dict[str, Any]]:
    """One record per region: source, map, id, true type, every method's labels, features."""
    records = []
    for k, m in enumerate(maps):
        for i, truth in enumerate(m.truth):
            records.append(
                {
                    "source": m.source,
                    "map": m.map,
                    "id": int(m.features["id"][i]),
                    "truth": truth,
                    **{method: r["labels"][k][i] for method, r in result.items()},
                    "features": {n: round(float(m.features[n][i]), 4) for n in FEATURES},
                }
            )
    return records


#: Colours of the place types in the pictures.
PLACE_COLOURS = {
    "room": "#9ecae1",
    "corridor": "#fdae6b",
    "hall": "#a1d99b",
    "doorway": "#bcbddc",
}


def draw_labels(path: str | Path, labelled: LabelledMap, predicted: Sequence[str]) -> Path:
    """Write a PNG of one map: every region filled with the colour of its predicted type, a
    text "predicted / true" at its inside point, red where they differ (regions without a
    true type are left white)."""
    from matplotlib.colors import to_rgba
    from matplotlib.patches import Patch

    grid, labels = labelled.regions.grid, labelled.regions.labels
    fig, ax = _map_figure(grid)
    ids = labelled.features["id"].astype(int)
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
    for region, place, true in zip(ids, predicted, labelled.truth, strict=True):
        depth = clearance_of(labels == region, 1.0)  # where the region's text goes
        x, y = labelled.regions.grid.cell_to_world(*np.unravel_index(depth.argmax(), depth.shape))
        wrong = place != true
        ax.annotate(
            f"{region}: {place}" + (f" / {true}" if wrong else ""),
            (float(x), float(y)),
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
    errors = sum(p != t for p, t in zip(predicted, labelled.truth, strict=True))
    title = f"{labelled.map}: predicted (red: predicted / true), {errors} of {len(ids)} wrong"
    return _save(fig, ax, path, title)
