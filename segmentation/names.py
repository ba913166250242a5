"""Regions by id or name: the one place a query ("hall 1", "Aisle 2", 3) becomes a region id,
for the planners, the region routes and the facade alike.

Names are the region graph's ``name`` node attribute (given by :mod:`topomap.labels`); they
match case-insensitively, with single spaces, and a synonym's first word stands for its place
type ("aisle 2" is "corridor 2").
"""

from __future__ import annotations

import difflib
import re
from typing import Any

import networkx as nx
import numpy as np

from segmentation.errors import RegionNotFoundError

#: Other words for a place type, accepted in names and queries ("aisle 2" is "corridor 2").
SYNONYMS = {"aisle": "corridor", "hallway": "corridor", "door": "doorway"}


def normalise_name(text: str) -> str:
    """A name as compared: lower case, single spaces, a synonym's first word replaced.

    Examples
    --------
    >>> normalise_name("  Aisle   2 ")
    'corridor 2'
    """
    words = re.sub(r"\s+", " ", text.strip().lower()).split(" ")
    words[0] = SYNONYMS.get(words[0], words[0])
    return " ".join(words)


def natural_key(text: str) -> list[Any]:
    """Sort key putting ``"room 2"`` before ``"room 10"``.

    Examples
    --------
    >>> sorted(["room 10", "hall 1", "room 2"], key=natural_key)
    ['hall 1', 'room 2', 'room 10']
    """
    return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", text.lower())]


def find_region(graph: nx.Graph, query: int | np.integer | str) -> int:
    """The region id of ``query``: an id (an integer or a string of digits) or a name.

    Raises
    ------
    RegionNotFoundError
        No such region; the message lists the ids, or the names in natural order with the
        closest one suggested.

    Examples
    --------
    >>> graph = nx.Graph()
    >>> graph.add_nodes_from([(1, {"name": "corridor 1"}), (2, {"name": "room 2"})])
    >>> find_region(graph, "Aisle 1"), find_region(graph, 2), find_region(graph, "2")
    (1, 2, 2)
    >>> find_region(graph, "rom 2")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    segmentation.errors.RegionNotFoundError: no region named 'rom 2' (did you mean 'room 2'?)...
    """
    if isinstance(query, int | np.integer) and not isinstance(query, bool):
        region = int(query)
    elif isinstance(query, str) and _is_id(query.strip()):
        region = int(query.strip())
    elif isinstance(query, str):
        return _by_name(graph, query)
    else:
        raise RegionNotFoundError(f"a region is an id or a name, got {query!r}")
    if region not in graph:
        raise RegionNotFoundError(f"no region {region}; ids: {sorted(graph.nodes)}")
    return region


def _by_name(graph: nx.Graph, query: str) -> int:
    wanted = normalise_name(query)
    names = {
        normalise_name(str(name)): int(region)
        for region, name in graph.nodes(data="name")
        if name is not None
    }
    if wanted in names:
        return names[wanted]
    known = sorted((str(n) for _, n in graph.nodes(data="name") if n is not None), key=natural_key)
    close = difflib.get_close_matches(wanted, list(names), n=1)
    hint = ""
    if close:
        hint = f" (did you mean {graph.nodes[names[close[0]]]['name']!r}?)"
    raise RegionNotFoundError(
        f"no region named {query!r}{hint}; known names: {', '.join(known) or 'none'}"
    )


def _is_id(text: str) -> bool:
    """Whether ``text`` reads as a region id: ASCII digits ("²" is a digit, not a number),
    fewer than 19 of them (an id fits 64 bits; a longer run of digits is a name).

    Examples
    --------
    >>> _is_id("12"), _is_id("²"), _is_id("9" * 5000), _is_id("")
    (True, False, False, False)
    """
    return text.isascii() and text.isdecimal() and len(text) < 19
