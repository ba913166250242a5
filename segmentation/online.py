"""Online segmentation while the robot explores (the paper's Section IV).

The offline spectral partition of the first keyframes is the *seed*; every later keyframe is
assigned as it arrives, at a cost that does not grow with the number of keyframes seen.

Centres
-------
A cluster centre ``Z`` is the running mean of its members' *hit histograms*: a scan ``X`` is the
set of map cells (``resolution`` metres, in the map frame) its valid beams end in, i.e. an
indicator vector over the cells, and ``Z(t) = (X_1 + ... + X_t) / t`` is, for each cell, the
fraction of the ``t`` members that hit it. Eq. 15, ``Z(t+1) = (t Z(t) + X) / (t + 1)``, is then
exact (centres are stored as integer hit counts and their member count). A mean of raw end
points or of poses would not do: scans of one room taken from different places hit different
walls, so their points cannot be paired and averaged, whereas their cells can.

Similarity of a scan (or a centre) ``A`` to a centre ``B``
    With the nearest-neighbour criterion (eq. 12, truncated at ``tol``; ``F_H`` the truncated
    closeness field ``tol - min(d(c, cells of H), tol)`` of the cells ``H`` ever hit)::

        S(A, B) = (sum_c A(c) F_B(c) / |A|  +  sum_c B(c) F_A(c) / |B|) / (2 tol)

    with ``|H| = sum_c H(c)``: the mean closeness of ``A``'s hits to what ``B`` saw, and the
    closeness of ``B``'s hits to what ``A`` saw, weighted by how often ``B``'s members hit them.
    For two single scans this is eq. 12 exactly (tested against the offline matrix). Any other
    criterion (``hausdorff``, ``features``, a callable) compares a scan with a centre through
    its own ``affinity`` on the scan and a *centre keyframe*: the centre's most frequently hit
    cells, as many as its members hit on average (for one member: that member's cells).

S as a distance
    ``D = 1 - min(S / S_ref, 1)`` with ``S_ref`` the largest similarity of the seed's keyframe
    pairs, so ``D`` is 0 for the most similar pair the seed had and 1 for nothing in common.

Threshold ``T``
    "The maximum similarity between clusters": the largest ``S`` between two different seed
    centres, as a distance: ``T = min over seed cluster pairs (a, b) of D(Z_a, Z_b)``. A scan
    farther than ``T`` from every centre is less like any cluster than the two most alike
    clusters are like each other.

Rules for a new scan ``X`` (the paper's, with its open cases decided):
    - ``D(X, Z_j) <= theta T`` for some ``j``: ``X`` joins the nearest such centre (several
      centres accept: the nearest one, ties to the lowest id) and moves it (eq. 15);
    - ``D(X, Z_j) >= T`` for every ``j``: ``X`` starts a new cluster and is its centre;
    - otherwise (undecided for every centre that does not reject it): ``X`` joins the nearest
      centre *without moving it*, so an uncertain scan never drags a centre across a door.

Merging
    A cluster created online that still has fewer than ``min_members`` keyframes ``patience``
    keyframes after its creation (a door or a glimpse, not a place) merges into the adjacent
    cluster whose centre is nearest (adjacent: its centre's cells share a tile with the small
    one's). With ``max_clusters``, when there are more clusters, the smallest of the clusters
    the new scan was compared with merges into its nearest adjacent one. The larger of the two
    keeps its id; ids are never reused.

Cost
    Centres are indexed by the ``tile`` x ``tile`` metre tiles their cells fall in; a scan is
    compared only with the centres in its tiles, each comparison touching only the cells near
    the scan's hits, so a keyframe's cost depends on the map around it, not on the keyframes
    seen.
"""

from __future__ import annotations

import heapq
import logging
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

import networkx as nx
import numpy as np
from numpy.typing import NDArray

from maps.scan import Keyframe, LaserScan
from segmentation.base import Estimator, clone
from segmentation.errors import ParameterError, SegmentationError
from segmentation.online_regions import OnlineRegions
from segmentation.similarity import NearestNeighbour, as_criterion, cell_keys
from segmentation.spectral import SpectralSegmenter

log = logging.getLogger(__name__)

#: Cell size of the centres' histograms for criteria other than ``nn`` (metres).
HISTOGRAM_RESOLUTION = 0.1


class OnlineStateError(SegmentationError):
    """``partial_fit`` (or a query) before ``fit``."""


@dataclass(frozen=True)
class Event:
    """Something that happened to a region when a keyframe arrived.

    Attributes
    ----------
    kind
        ``"created"`` (a new region, with this keyframe as its centre; seed regions are created
        at the last seed keyframe), ``"grown"`` (the keyframe joined ``region``) or
        ``"merged"`` (``absorbed`` merged into ``region``, which keeps its id), ``"split"``
        (``region`` is a new piece of ``source``) or ``"moved"`` (the keyframes ``members``
        went from ``source`` to ``region``).
    keyframe
        Index of the keyframe (0-based, over the seed and everything after it).
    region
        The region created, grown or surviving the merge.
    absorbed
        For ``"merged"``: the id that disappears.
    source
        For ``"split"``: the region the new one was a piece of; for ``"moved"``: the region
        the keyframes left.
    members
        For ``"moved"``: the keyframes that moved.
    distance
        For ``"grown"`` / ``"created"`` after the seed: the scan's distance ``D`` to the
        nearest centre (1.0 when no centre was near).
    decided
        For ``"grown"``: ``True`` when the centre accepted the scan (``D <= theta T``) and
        moved, ``False`` for an undecided scan that joined without moving it.
    """

    kind: Literal["created", "grown", "merged", "split", "moved"]
    keyframe: int
    region: int
    absorbed: int | None = None
    source: int | None = None
    members: tuple[int, ...] | None = None
    distance: float | None = None
    decided: bool | None = None

    def as_dict(self) -> dict[str, Any]:
        """The event as a plain dict, without the fields that do not apply."""
        return {k: v for k, v in asdict(self).items() if v is not None}


@dataclass
class Centre:
    """A cluster centre: hit counts per cell (eq. 15 as integer sums) and its keyframes.

    ``Z(c) = counts[c] / members`` where ``members`` counts the keyframes that moved the centre
    (undecided keyframes join ``keyframes`` without moving it); ``mass = sum(counts)``.
    """

    counts: dict[int, int]
    members: int
    mass: int
    tiles: set[int]
    keyframes: list[int]
    born: int

    def arrays(self) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """Cell keys and hit counts."""
        size = len(self.counts)
        keys = np.fromiter(self.counts.keys(), np.int64, size)
        return keys, np.fromiter(self.counts.values(), np.int64, size)


def _decode(keys: NDArray[np.int64]) -> NDArray[np.int64]:
    """Cells ``(m, 2)`` of :func:`segmentation.similarity.cell_keys`."""
    low = (keys & 0xFFFFFFFF).astype(np.int64)
    low = np.where(low >= 2**31, low - 2**32, low)
    return np.column_stack([(keys - low) >> 32, low])


def _cells(points: NDArray[np.float64], resolution: float) -> NDArray[np.int64]:
    """Keys of the unique cells hit by ``points``."""
    return np.unique(cell_keys(np.floor(points / resolution).astype(np.int64)))


@dataclass(frozen=True, eq=False)
class CentreKeyframe(Keyframe):
    """A centre seen as a keyframe by criteria that take keyframes: its ``points()`` are the
    centres of its most frequently hit cells, in angular order around their mean."""

    cloud: NDArray[np.float64] = field(default_factory=lambda: np.empty((0, 2)))

    def points(self) -> NDArray[np.float64]:
        """The centre's cells in metres, map frame."""
        return self.cloud


_NO_SCAN = LaserScan(np.ones(1), 0.0, 1.0)


@dataclass
class OnlineSegmenter(Estimator):
    """Segment keyframes as they arrive: a spectral seed, then the paper's online rules.

    See the module docstring for the centres, ``T``, the rules and the merging.

    Parameters
    ----------
    segmenter
        The offline partition of the seed (its criterion is used online too);
        ``SpectralSegmenter()`` by default.
    theta
        In ``[0, 1]``: a centre accepts a scan within ``theta T``.
    max_clusters
        "Too many clusters": above this many, small adjacent ones merge. ``None``: as many as
        the seed had per tile of explored map, times the tiles explored so far.
    patience
        A cluster younger than this many keyframes is not merged (it may be a room the robot
        is just entering).
    tile
        Side of the spatial index's tiles, metres.
    max_gap
        A keyframe whose pose is farther than this many metres outside the bounding box of
        everything hit so far is refused (a jump, not exploration).
    dense
        Keep the dense regions and the region graph (:class:`OnlineRegions`) up to date.
    region_resolution, reach
        Cell size and claiming reach of the dense regions (metres).

    Attributes
    ----------
    segmenter_ : SpectralSegmenter
        The seed's partition: a fitted copy of ``segmenter`` (the one given is never fitted).
    labels_ : ndarray of int
        Region id of every keyframe so far (ids start at 1; a merged id is replaced).
    arrival_labels_ : ndarray of int
        Region id each keyframe was given when it arrived.
    centres_ : dict of int to Centre
        Live centres by region id.
    threshold_ : float
        ``T``.
    similarity_scale_ : float
        ``S_ref``.
    n_seed_ : int
        Keyframes in the seed.
    events_ : list of Event
    regions_ : OnlineRegions or None
        The dense regions and the region graph (``region_at``, ``graph_``).

    Examples
    --------
    >>> import maps
    >>> plan = maps.generate_floor_plan("flat", random_state=0)
    >>> route = maps.wander(plan.grid, plan.labels, random_state=0)
    >>> scans = maps.simulate_scans(plan.grid, route.poses, maps.LaserModel(), random_state=0)
    >>> keyframes = maps.select_keyframes(scans)
    >>> online = OnlineSegmenter(SpectralSegmenter(random_state=0)).fit(keyframes[:80])
    >>> regions = online.partial_fit(keyframes[80:])
    >>> len(online.labels_) == len(keyframes), 0 < online.threshold_ <= 1
    (True, True)
    """

    segmenter: SpectralSegmenter | None = None
    theta: float = 0.5
    max_clusters: int | None = None
    patience: int = 20
    tile: float = 3.2
    max_gap: float = 10.0
    dense: bool = True
    region_resolution: float = 0.2
    reach: float = 4.0
    segmenter_: SpectralSegmenter = field(init=False, repr=False)
    centres_: dict[int, Centre] = field(init=False, repr=False)
    threshold_: float = field(init=False, repr=False)
    similarity_scale_: float = field(init=False, repr=False)
    n_seed_: int = field(init=False, repr=False)
    events_: list[Event] = field(init=False, repr=False)
    regions_: OnlineRegions | None = field(init=False, repr=False)

    def _validate_params(self) -> None:
        if not (isinstance(self.theta, int | float) and 0 <= self.theta <= 1):
            raise ParameterError(f"theta must lie in [0, 1], got {self.theta!r}")
        if not isinstance(self.patience, int | np.integer) or self.patience < 0:
            raise ParameterError(f"patience must be an integer >= 0, got {self.patience!r}")
        if self.max_clusters is not None and not (
            isinstance(self.max_clusters, int | np.integer) and self.max_clusters >= 1
        ):
            raise ParameterError(f"max_clusters must be an integer >= 1, got {self.max_clusters!r}")
        for name in ("tile", "max_gap", "region_resolution", "reach"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ParameterError(f"{name} must be a finite number > 0 metres, got {value!r}")
        if self.segmenter is not None:
            self.segmenter._validate_params()

    def _prepare(self, segmenter: SpectralSegmenter) -> None:
        """What the criterion of the seed's segmenter decides: the histograms' cell size, the
        tiles, and for ``nn`` the offsets and closeness of eq. 12's truncated field."""
        criterion = as_criterion(segmenter.criterion)
        self._criterion = criterion
        self._nn = criterion if isinstance(criterion, NearestNeighbour) else None
        self._resolution = self._nn.resolution if self._nn else HISTOGRAM_RESOLUTION
        self._tile_bits = max(0, int(math.floor(math.log2(self.tile / self._resolution))))
        if self._nn is not None:
            reach = math.ceil(self._nn.tolerance / self._resolution)
            di, dj = np.mgrid[-reach : reach + 1, -reach : reach + 1].reshape(2, -1)
            distance = self._resolution * np.hypot(di, dj)
            near = distance < self._nn.tolerance
            self._offsets = np.column_stack([di[near], dj[near]]).astype(np.int64)
            self._closeness = self._nn.tolerance - distance[near]

    # ----------------------------------------------------------------------------- fitting
    def fit(self, keyframes: Sequence[Keyframe]) -> OnlineSegmenter:
        """Build the seed: the offline partition of ``keyframes``, its centres and ``T``.

        Raises
        ------
        SegmentationError
            No keyframes, a keyframe with no valid beam or a pose that is not finite, or a
            seed of a single cluster (``T`` needs two).
        """
        self._validate_params()
        self._fitted = False
        self.segmenter_ = segmenter = clone(self.segmenter or SpectralSegmenter())
        self._prepare(segmenter)
        scans = [self._scan(k, i) for i, k in enumerate(keyframes)]
        if not scans:
            raise SegmentationError("no keyframes to seed the online segmentation")
        segmenter.fit(keyframes)
        if segmenter.n_regions_ < 2:
            raise SegmentationError(
                f"the seed of {len(keyframes)} keyframes has {segmenter.n_regions_} cluster; "
                "T needs two: give more seed keyframes"
            )
        labels = segmenter.labels_.astype(np.int64) + 1
        n = len(keyframes)
        self.similarity_scale_ = float(segmenter.affinity_.data.max(initial=0.0)) or 1.0
        self._empty_store()
        for i, ((keys, tiles, _), region) in enumerate(zip(scans, labels.tolist(), strict=True)):
            if region not in self.centres_:
                self.centres_[region] = Centre({}, 0, 0, set(), [], n - 1)
            self._join(region, i, keys, tiles, move=True)
        self.threshold_ = self._seed_threshold(keyframes, scans)
        self._density = len(self.centres_) / len(self._seen_tiles)
        self._labels = np.zeros(max(16, 2 * n), np.int64)
        self._arrival = np.zeros_like(self._labels)
        self._labels[:n] = self._arrival[:n] = labels
        self._n = self.n_seed_ = n
        self._next_id = int(labels.max()) + 1
        points = np.concatenate([p for _, _, p in scans])
        self._low, self._high = points.min(axis=0), points.max(axis=0)
        self.events_ = [Event("created", n - 1, r) for r in sorted(self.centres_)]
        self.regions_ = None
        if self.dense:
            self.regions_ = OnlineRegions(self.region_resolution, self.reach)
            for i, keyframe in enumerate(keyframes):
                self.regions_.add(i, keyframe, int(labels[i]))
        self._fitted = True
        log.info(
            "seed: %d keyframes, %d clusters, T = %.3f", n, len(self.centres_), self.threshold_
        )
        return self

    def _empty_store(self) -> None:
        """No centre yet: the centres, the cell index and the tile index."""
        self.centres_ = {}
        # the cell index: cell key -> row; per row up to `width` (region, hits) of the centres
        # that hit the cell (region 0 = free entry), so lookups are vectorised
        self._rows: dict[int, int] = {}
        self._row_region = np.zeros((1024, 4), np.int32)
        self._row_hits = np.zeros((1024, 4), np.int32)
        self._tile_index: dict[int, set[int]] = {}
        self._seen_tiles: set[int] = set()
        self._cached: dict[int, CentreKeyframe] = {}
        self._heap: list[tuple[int, int]] = []

    def _index_rows(self, keys: NDArray[np.int64], create: bool) -> NDArray[np.int64]:
        """Rows of the cell index for ``keys`` (-1 for a cell no centre hit unless ``create``)."""
        if not create:
            get = self._rows.get
            return np.fromiter((get(k, -1) for k in keys.tolist()), np.int64, len(keys))
        rows = self._rows
        found = np.fromiter((rows.setdefault(k, len(rows)) for k in keys.tolist()), np.int64)
        if len(rows) > len(self._row_region):
            extra = ((0, max(len(rows), 2 * len(self._row_region)) - len(self._row_region)), (0, 0))
            self._row_region = np.pad(self._row_region, extra)
            self._row_hits = np.pad(self._row_hits, extra)
        return found

    def _index_add(self, region: int, keys: NDArray[np.int64], hits: NDArray[np.int64]) -> None:
        """``region``'s centre hit the cells ``keys`` (unique) ``hits`` more times."""
        rows = self._index_rows(keys, create=True)
        while True:
            table = self._row_region[rows]
            match = table == region
            has = match.any(axis=1)
            free = table == 0
            if np.all(has | free.any(axis=1)):
                break
            # a cell hit by more centres than a row holds: widen the rows
            self._row_region = np.hstack([self._row_region, np.zeros_like(self._row_region)])
            self._row_hits = np.hstack([self._row_hits, np.zeros_like(self._row_hits)])
        column = np.where(has, match.argmax(axis=1), free.argmax(axis=1))
        self._row_region[rows, column] = region
        self._row_hits[rows, column] += hits

    def _seed_threshold(self, keyframes: Sequence[Keyframe], scans: list[Any]) -> float:
        """``T``: over pairs of seed clusters ``(a, b)`` that are near each other, the smallest
        mean of ``D(X_i, Z_other)`` over the members of both (a member not near the other
        centre counts 1); see the module docstring."""
        labels = np.zeros(len(keyframes), np.int64)
        for region, centre in self.centres_.items():
            labels[centre.keyframes] = region
        found: dict[tuple[int, int], list[float]] = {}
        for i, (keyframe, (keys, tiles, _)) in enumerate(zip(keyframes, scans, strict=True)):
            own = int(labels[i])
            others, distances = self._compare(keys, None, tiles, keyframe, own)
            for other, distance in zip(others, distances.tolist(), strict=True):
                pair = found.setdefault((min(own, other), max(own, other)), [0.0, 0.0])
                pair[0] += distance
                pair[1] += 1
        means = []
        for (a, b), (total, computed) in found.items():
            members = len(self.centres_[a].keyframes) + len(self.centres_[b].keyframes)
            means.append((total + members - computed) / members)
        return float(min(means, default=1.0))

    def partial_fit(self, keyframes: Keyframe | Sequence[Keyframe]) -> int | list[int]:
        """Assign one keyframe (returns its region id) or a batch (returns a list).

        Keyframes of a batch are assigned in order; a refused keyframe raises and leaves the
        segmenter as it was before that keyframe.

        Raises
        ------
        OnlineStateError
            Before :meth:`fit`.
        SegmentationError
            A keyframe with no valid beam, a pose that is not finite, or a pose more than
            ``max_gap`` metres outside everything hit so far.
        """
        if not getattr(self, "_fitted", False):
            raise OnlineStateError("partial_fit before fit: fit the seed keyframes first")
        if isinstance(keyframes, Keyframe):
            return self._assign(keyframes)
        return [self._assign(k) for k in keyframes]

    # ----------------------------------------------------------------------------- queries
    @property
    def labels_(self) -> NDArray[np.int64]:
        """Region id of every keyframe so far (ids start at 1; a merged id is replaced)."""
        self._check_fitted()
        return self._labels[: self._n].copy()

    @property
    def arrival_labels_(self) -> NDArray[np.int64]:
        """Region id each keyframe was given when it arrived."""
        self._check_fitted()
        return self._arrival[: self._n].copy()

    @property
    def n_regions_(self) -> int:
        """Number of live regions."""
        self._check_fitted()
        return len(self.centres_)

    def region_at(self, x: float, y: float) -> int:
        """Region id at map point ``(x, y)`` in the dense regions, 0 if none."""
        return self._dense().region_at(x, y)

    @property
    def graph_(self) -> nx.Graph:
        """The region adjacency graph, kept up to date (see :class:`OnlineRegions`)."""
        return self._dense().graph

    def _dense(self) -> OnlineRegions:
        self._check_fitted()
        if self.regions_ is None:
            raise OnlineStateError("dense regions are off: build the segmenter with dense=True")
        return self.regions_

    def _check_fitted(self) -> None:
        if not getattr(self, "_fitted", False):
            raise OnlineStateError("the online segmenter is not fitted: call fit first")

    # ----------------------------------------------------------------------------- internals
    def _scan(
        self, keyframe: Keyframe, index: int
    ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
        """Cell keys, tile keys and points of a keyframe, or a SegmentationError."""
        if not isinstance(keyframe, Keyframe):
            raise SegmentationError(f"keyframe {index} is not a Keyframe: {keyframe!r}")
        if not np.all(np.isfinite(keyframe.pose)):
            raise SegmentationError(
                f"keyframe {index} (scan_index {keyframe.scan_index}) has a pose that is not "
                f"finite: {keyframe.pose}"
            )
        points = keyframe.points()
        if len(points) == 0:
            raise SegmentationError(
                f"keyframe {index} (scan_index {keyframe.scan_index}) has no valid beam"
            )
        keys = _cells(points, self._resolution)
        return keys, np.unique(cell_keys(_decode(keys) >> self._tile_bits)), points

    def _assign(self, keyframe: Keyframe) -> int:
        index = self._n
        keys, tiles, points = self._scan(keyframe, index)
        x, y = keyframe.pose[:2]
        gap = max(self._low[0] - x, x - self._high[0], self._low[1] - y, y - self._high[1])
        if gap > self.max_gap:
            raise SegmentationError(
                f"keyframe {index} (scan_index {keyframe.scan_index}) at ({x:.2f}, {y:.2f}) is "
                f"{gap:.1f} m outside the map so far (max_gap {self.max_gap} m)"
            )
        candidates, distances = self._compare(keys, None, tiles, keyframe, None)
        best = int(np.argmin(distances)) if candidates else -1
        nearest = float(distances[best]) if candidates else 1.0
        if candidates and nearest <= self.theta * self.threshold_:
            region, move = candidates[best], True
        elif nearest >= self.threshold_:
            region, move = self._next_id, True
        else:
            region, move = candidates[best], False
        # nothing above changed the state: from here on the keyframe is accepted
        if index >= len(self._labels):
            self._labels = np.concatenate([self._labels, np.zeros_like(self._labels)])
            self._arrival = np.concatenate([self._arrival, np.zeros_like(self._arrival)])
        self._labels[index] = self._arrival[index] = region
        self._n += 1
        self._low = np.minimum(self._low, points.min(axis=0))
        self._high = np.maximum(self._high, points.max(axis=0))
        if region == self._next_id:
            self._next_id += 1
            self.centres_[region] = Centre({}, 0, 0, set(), [], index)
            self.events_.append(Event("created", index, region, distance=round(nearest, 6)))
        else:
            self.events_.append(
                Event("grown", index, region, distance=round(nearest, 6), decided=move)
            )
        self._join(region, index, keys, tiles, move)
        if self.regions_ is not None:
            self.regions_.add(index, keyframe, region)
        self._merge_small(index)
        return int(self._labels[index])

    def _join(
        self, region: int, index: int, keys: NDArray[np.int64], tiles: NDArray[np.int64], move: bool
    ) -> None:
        """Keyframe ``index`` joins ``region``; with ``move`` its hits move the centre (eq. 15)."""
        centre = self.centres_[region]
        centre.keyframes.append(index)
        heapq.heappush(self._heap, (len(centre.keyframes), region))
        self._seen_tiles.update(tiles.tolist())
        if not move:
            return
        counts = centre.counts
        for key in keys.tolist():
            counts[key] = counts.get(key, 0) + 1
        self._index_add(region, keys, np.ones(len(keys), np.int64))
        centre.members += 1
        centre.mass += len(keys)
        for tile in tiles.tolist():
            if tile not in centre.tiles:
                centre.tiles.add(tile)
                self._tile_index.setdefault(tile, set()).add(region)
        self._cached.pop(region, None)

    def _merge_small(self, index: int) -> None:
        """While there are too many clusters, merge the smallest one old enough into its
        nearest neighbour."""
        cap = self.max_clusters or math.ceil(self._density * len(self._seen_tiles))
        kept: list[tuple[int, int]] = []
        while len(self.centres_) > cap and self._heap:
            size, region = heapq.heappop(self._heap)
            centre = self.centres_.get(region)
            if centre is None or len(centre.keyframes) != size:
                continue  # stale entry: the cluster grew or is gone
            if index - centre.born < self.patience:
                kept.append((size, region))
                continue
            keys, weights = centre.arrays()
            tiles = np.fromiter(centre.tiles, np.int64, len(centre.tiles))
            others, distances = self._compare(keys, weights, tiles, None, region)
            if not others:
                kept.append((size, region))
                continue
            self._merge(others[int(np.argmin(distances))], region, index)
        for entry in kept:
            heapq.heappush(self._heap, entry)

    def _merge(self, a: int, b: int, index: int) -> None:
        """Merge clusters ``a`` and ``b``; the one with more keyframes (ties: lower id) keeps
        its id. The centre is the members-weighted mean of both (eq. 15 summed)."""
        if (len(self.centres_[b].keyframes), -b) > (len(self.centres_[a].keyframes), -a):
            a, b = b, a
        kept, gone = self.centres_[a], self.centres_.pop(b)
        for key, count in gone.counts.items():
            kept.counts[key] = kept.counts.get(key, 0) + count
        keys, hits = gone.arrays()
        rows = self._index_rows(keys, create=False)
        column = (self._row_region[rows] == b).argmax(axis=1)
        self._row_region[rows, column] = 0
        self._row_hits[rows, column] = 0
        self._index_add(a, keys, hits)
        kept.members += gone.members
        kept.mass += gone.mass
        kept.keyframes.extend(gone.keyframes)
        for tile in gone.tiles:
            self._tile_index[tile].discard(b)
            self._tile_index[tile].add(a)
        kept.tiles |= gone.tiles
        kept.born = min(kept.born, gone.born)
        heapq.heappush(self._heap, (len(kept.keyframes), a))
        self._cached.pop(a, None)
        self._cached.pop(b, None)
        self._labels[np.asarray(gone.keyframes, np.int64)] = a
        if self.regions_ is not None:
            self.regions_.merge(a, b)
        self.events_.append(Event("merged", index, a, absorbed=b))

    # ------------------------------------------------------------------------ similarities
    def _compare(
        self,
        keys: NDArray[np.int64],
        weights: NDArray[np.int64] | None,
        tiles: NDArray[np.int64],
        keyframe: Keyframe | None,
        own: int | None,
    ) -> tuple[list[int], NDArray[np.float64]]:
        """The centres near ``A`` (other than ``own``) and ``D(A, Z)`` for each.

        ``A`` is a scan (``keyframe``, its hit cells ``keys``, ``weights`` None) or the centre
        ``own`` (its ``keys`` and hit counts ``weights``). With ``nn`` the centres near ``A``
        are those with a hit within the tolerance of one of ``A``'s (the others have ``S = 0``);
        with other criteria those sharing one of ``A``'s ``tiles``.
        """
        if self._nn is not None:
            ones = np.ones(len(keys), np.int64)
            found, similarity = self._nn_similarities(
                keys, ones if weights is None else weights, own
            )
            return found, self._as_distance(similarity)
        near = set().union(*(self._tile_index.get(t, set()) for t in tiles.tolist()))
        others = sorted(near - {own})
        if not others:
            return [], np.zeros(0)
        first = keyframe if keyframe is not None else self._centre_keyframe(int(own or 0))
        frames = [first, *(self._centre_keyframe(c) for c in others)]
        return others, self._as_distance(self._criterion.affinity(frames).toarray()[0, 1:])

    def _as_distance(self, similarity: NDArray[np.float64]) -> NDArray[np.float64]:
        return 1.0 - np.minimum(similarity / self.similarity_scale_, 1.0)

    def _nn_similarities(
        self, keys: NDArray[np.int64], weights: NDArray[np.int64], own: int | None
    ) -> tuple[list[int], NDArray[np.float64]]:
        """The centres with a hit within the tolerance of ``A``'s hits (other than ``own``)
        and ``S(A, B)`` of the module docstring for each; ``A`` is given by the cell keys of
        its hits and their counts."""
        assert self._nn is not None
        cells = _decode(keys)
        around = cell_keys((cells[:, None, :] + self._offsets[None, :, :]).reshape(-1, 2))
        unique, inverse = np.unique(around, return_inverse=True)
        rows = self._index_rows(unique, create=False)
        near = np.flatnonzero(rows >= 0)
        table, hits = self._row_region[rows[near]], self._row_hits[rows[near]]
        entry = (table > 0) & (table != (own or 0))
        at, slot = np.nonzero(entry)
        if len(at) == 0:
            return [], np.zeros(0)
        regions, column = np.unique(table[at, slot], return_inverse=True)
        found = np.zeros((len(unique), len(regions)))
        found[near[at], column] = hits[at, slot]
        closeness = np.tile(self._closeness, len(keys))
        # F_A around A's cells: the best closeness of A's hits
        field_a = np.zeros(len(unique))
        np.maximum.at(field_a, inverse, closeness)
        # F_B at A's cells: the best closeness of B's hits around each of them
        close = np.where(found[inverse] > 0, closeness[:, None], 0.0)
        near_b = close.reshape(len(keys), len(self._offsets), -1).max(axis=1)
        mass = np.array([self.centres_[r].mass for r in regions.tolist()], np.float64)
        first = weights @ near_b / float(weights.sum())
        second = field_a @ found / mass
        return regions.tolist(), (first + second) / (2 * self._nn.tolerance)

    def _centre_keyframe(self, region: int) -> CentreKeyframe:
        """The centre's most hit cells (as many as a member hits on average) as a keyframe."""
        if region not in self._cached:
            centre = self.centres_[region]
            keys, counts = centre.arrays()
            size = max(1, round(centre.mass / centre.members))
            top = np.lexsort((keys, -counts))[:size]
            points = ((_decode(keys[top]) + 0.5) * self._resolution).astype(np.float64)
            mean = points.mean(axis=0)
            angle = np.arctan2(points[:, 1] - mean[1], points[:, 0] - mean[0])
            cloud = points[np.argsort(angle, kind="stable")]
            self._cached[region] = CentreKeyframe((*mean, 0.0), _NO_SCAN, 0, None, cloud)
        return self._cached[region]
