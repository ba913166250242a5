"""The label evaluation's per-region records, per-map counts and pictures, on a hand-made
building whose true types are drawn by hand."""

import numpy as np
from matplotlib.image import imread

from maps.grid import OccupancyGrid
from segmentation.graph import region_graph
from segmentation.regions import Regions
from topomap.cli.evaluate_labels import (
    draw_labels,
    evaluate_labels,
    labelled_regions,
    train_on_all,
)
from topomap.labels import PLACE_TYPES, ForestClassifier, feature_matrix


def _labelled(name: str) -> dict:
    """A 20 x 2 m corridor (id 1) with two 4 x 5 m rooms (2, 3) above it and a 4 x 5 m room
    (4) below it, at 10 cm cells; the truth calls room 3 a corridor (a mistake to find)."""
    labels = np.zeros((120, 220), np.int32)
    labels[50:70, 10:210] = 1
    labels[5:49, 10:60] = 2
    labels[49:50, 30:40] = 2
    labels[5:49, 70:120] = 3
    labels[49:50, 90:100] = 3
    labels[71:115, 10:60] = 4
    labels[70:71, 30:40] = 4
    grid = OccupancyGrid(np.where(labels > 0, 0, 100).astype(np.int8), 0.1)
    regions = Regions(grid, labels)
    truth = np.full(labels.shape, -1, np.int8)
    truth[labels > 0] = PLACE_TYPES.index("room")
    truth[(labels == 1) | (labels == 3)] = PLACE_TYPES.index("corridor")
    return labelled_regions(regions, region_graph(regions), truth, name)


def test_records_counts_and_pictures(tmp_path):
    maps = [_labelled("a"), _labelled("b")]
    scores, records, counts = evaluate_labels(maps)
    assert [(r["map"], r["id"], r["truth"], r["rules"]) for r in records[:4]] == [
        ("a", 1, "corridor", "corridor"),
        ("a", 2, "room", "room"),
        ("a", 3, "corridor", "room"),
        ("a", 4, "room", "room"),
    ]
    assert records[0]["features"]["doors"] == 3
    assert records[0]["features"]["area_m2"] > 39
    assert scores["rules"]["per_class"]["corridor"] == {
        "precision": 1.0,
        "recall": 0.5,
        "f1": 0.667,
        "support": 4,
    }
    assert counts[1]["map"] == "b" and counts[1]["corridors"] == 2
    assert counts[1]["rules"] == {"corridors found": 1, "corridors invented": 0, "wrong": 1}
    picture = draw_labels(tmp_path / "a.png", maps[0], [r["rules"] for r in records[:4]])
    image = imread(picture)
    assert image.shape[0] > 100 and image.shape[1] > 100
    # the rooms' blue and the corridor's orange are both in the picture
    rgb = (image[..., :3] * 255).round().astype(int)
    for colour in ((0x9E, 0xCA, 0xE1), (0xFD, 0xAE, 0x6B)):
        mixed = 0.85 * np.array(colour)
        assert (np.abs(rgb - mixed - 0.15 * 255).sum(axis=2) < 12).any()


def test_a_forest_trained_on_all_maps_saves_as_json(tmp_path):
    maps = [_labelled("a"), _labelled("b")]
    model = train_on_all(maps)
    found = model.predict(feature_matrix(maps[0]["features"]))
    # the corridor and the room below are learnt; rooms 2 and 3 have the same features and
    # two different true types, so no model can get both
    assert (found[0], found[3]) == ("corridor", "room")
    again = ForestClassifier.load(model.save(tmp_path / "model.json"))
    assert again.predict(feature_matrix(maps[1]["features"])) == found
