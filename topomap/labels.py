"""Region labels (room, corridor, hall, doorway) and human names ("corridor 2", "hall 1").

:func:`label_graph` measures the regions (:mod:`topomap.features`), runs a classifier
(:mod:`topomap.classifiers`, the rules by default) and names the regions; a name given with
:func:`rename` is kept through later labelling.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import networkx as nx

from segmentation.names import find_region, normalise_name
from segmentation.regions import Regions
from topomap.classifiers import PLACE_TYPES, Classifier, classify
from topomap.errors import LabelError
from topomap.features import region_features

#: The node attribute that marks a name a user gave (kept when the map is labelled again).
GIVEN = "name_given"


def name_regions(
    graph: nx.Graph, labels: Mapping[int, str], taken: Mapping[int, str] | None = None
) -> dict[int, str]:
    """Unique names "<label> <n>", numbered per label in reading order (top to bottom, then
    left to right, by each region's inside point); regions in ``taken`` keep their name, and
    no other region gets one of those names.

    Examples
    --------
    >>> graph = nx.Graph()
    >>> graph.add_nodes_from([(1, {"x": 0.0, "y": 5.0}), (2, {"x": 0.0, "y": 0.0})])
    >>> sorted(name_regions(graph, {1: "room", 2: "room"}, taken={2: "room 1"}).items())
    [(1, 'room 2'), (2, 'room 1')]
    """
    taken = dict(taken or {})
    used = {normalise_name(name) for name in taken.values()}
    names = dict(taken)
    for place in PLACE_TYPES:
        members = [r for r, label in labels.items() if label == place and r not in taken]
        members.sort(key=lambda r: (-round(graph.nodes[r]["y"], 1), graph.nodes[r]["x"]))
        number = 0
        for region in members:
            number += 1
            while f"{place} {number}" in used:
                number += 1
            names[region] = f"{place} {number}"
    return names


def label_graph(
    regions: Regions, graph: nx.Graph, classifier: Classifier | None = None
) -> dict[int, str]:
    """Label every region of ``graph`` with a place type (``classifier``, the rules by default)
    and a unique name, stored as the nodes' ``label`` and ``name``; returns id -> label.

    A name a user gave with :func:`rename` stays; the other regions are numbered anew.
    """
    features = region_features(regions, graph)
    found = classify(classifier, features)
    labels = dict(zip(features["id"].astype(int).tolist(), found, strict=True))
    given = {int(r): str(d["name"]) for r, d in graph.nodes(data=True) if d.get(GIVEN)}
    names = name_regions(graph, labels, given)
    for region in graph.nodes:
        graph.nodes[region]["label"] = labels[region]
        graph.nodes[region]["name"] = names[region]
    return labels


#: Characters a saved name cannot carry: XML 1.0 holds no control characters but tab, line
#: feed and carriage return (and reads a carriage return back as a line feed), no lone
#: surrogates and not U+FFFE / U+FFFF.
_UNSAVEABLE = re.compile("[\x00-\x1f\x7f\ud800-\udfff\ufffe\uffff]")


def rename(graph: nx.Graph, old: int | str, new: str) -> None:
    """Give a region (by id or name) a new name, kept when the map is labelled again; a name
    already taken, empty or only digits (it would read as a region id) is refused and nothing
    changes."""
    region = find_region(graph, old)
    if not isinstance(new, str):
        raise LabelError(f"a region name is a string, got {new!r}")
    if _UNSAVEABLE.search(new):
        raise LabelError(
            f"a region name holds printable characters and spaces only (it is saved in "
            f"GraphML), got {new!r}"
        )
    wanted = normalise_name(new)
    if not wanted:
        raise LabelError("a region name cannot be empty")
    if wanted.isdigit():
        raise LabelError(f"a region name cannot be only digits ({new!r} reads as a region id)")
    for other, name in graph.nodes(data="name"):
        if other != region and name is not None and normalise_name(str(name)) == wanted:
            raise LabelError(f"the name {new!r} is taken by region {other}")
    graph.nodes[region]["name"] = new.strip()
    graph.nodes[region][GIVEN] = True


def carry_names(graph: nx.Graph, previous: nx.Graph) -> None:
    """Regions of ``graph`` that continue a region of ``previous`` (same id) take its name back
    when their label is the same or a user gave the name; a region whose name one of them took
    (as queries compare names: "corridor 2" is "Aisle 2") gets the first free number of its
    label."""
    carried = {
        r: previous.nodes[r]["name"]
        for r, label in graph.nodes(data="label")
        if r in previous
        and (previous.nodes[r].get("label") == label or previous.nodes[r].get(GIVEN))
    }
    for region, name in carried.items():
        graph.nodes[region]["name"] = name
        if previous.nodes[region].get(GIVEN):
            graph.nodes[region][GIVEN] = True
    taken = {normalise_name(str(name)) for name in carried.values()}
    used = {normalise_name(str(name)) for _, name in graph.nodes(data="name")}
    for region in sorted(graph.nodes):
        data = graph.nodes[region]
        if region in carried or normalise_name(str(data["name"])) not in taken:
            continue
        number = 1  # a name a continued region took back: the first free number of its label
        while normalise_name(f"{data['label']} {number}") in used:
            number += 1
        data["name"] = f"{data['label']} {number}"
        used.add(normalise_name(data["name"]))
