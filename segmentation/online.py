"""Online segmentation by the paper's Section IV rules (the ``centres`` engine, a baseline; the
default engine is :mod:`segmentation.incremental`).

The offline spectral partition of the first keyframes is the *seed*; every later keyframe is
assigned as it arrives, at a cost that does not grow with the number of keyframes seen:

- a centre ``Z`` is the running mean of its members' *hit histograms* (the cells their beams
  end in), so eq. 15 is exact on integer hit counts (:class:`~segmentation.centres.Centre`);
- with ``nn``, ``S(A, B) = (sum_c A(c) F_B(c) / |A| + sum_c B(c) F_A(c) / |B|) / (2 tol)``,
  ``F_H`` the truncated closeness field of the cells ``H`` hit (eq. 12 for two scans); other
  criteria compare the scan with the centre's most hit cells; ``D = 1 - min(S / S_ref, 1)``;
- ``T`` is the smallest mean ``D`` between two seed clusters near each other; a scan with
  ``D <= theta T`` joins the nearest accepting centre and moves it, one with ``D >= T`` for
  every centre starts a cluster, any other joins the nearest centre without moving it;
- too many clusters: the smallest one old enough merges into its nearest adjacent one (the
  larger keeps its id; ids are never reused);
- the centres near a scan come from a cell index (:class:`~segmentation.centres.CellIndex`).

The derivation and the choices: ``docs/online.md``.
"""

from __future__ import annotations

import heapq
import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from maps.limits import finite_in
from maps.scan import Keyframe
from segmentation.base import check_flags, check_lengths, clone, is_count
from segmentation.centres import (
    CellIndex,
    Centre,
    CentreKeyframe,
    cells_of,
    centre_similarities,
    decode,
)
from segmentation.closeness import Closeness
from segmentation.distinct import distinct
from segmentation.errors import ParameterError, SegmentationError
from segmentation.events import Event, OnlineEstimator
from segmentation.online_regions import OnlineRegions
from segmentation.similarity import NearestNeighbour, as_criterion, cell_keys
from segmentation.spectral import SpectralSegmenter

log = logging.getLogger(__name__)

#: Cell size of the centres' histograms for criteria other than ``nn`` (metres).
HISTOGRAM_RESOLUTION = 0.1


@dataclass
class OnlineSegmenter(OnlineEstimator):
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
        if finite_in(self.theta, "theta", 0, 1) is not None:  # a bool is no number here
            raise ParameterError(f"theta must lie in [0, 1], got {self.theta!r}")
        check_flags(self, "dense")
        if not is_count(self.patience) or self.patience < 0:
            raise ParameterError(f"patience must be an integer >= 0, got {self.patience!r}")
        if self.max_clusters is not None and not (
            is_count(self.max_clusters) and self.max_clusters >= 1
        ):
            raise ParameterError(f"max_clusters must be an integer >= 1, got {self.max_clusters!r}")
        check_lengths(self, "tile", "max_gap", "region_resolution", "reach")
        if self.segmenter is not None:
            if not isinstance(self.segmenter, SpectralSegmenter):
                raise ParameterError(
                    f"segmenter must be a SpectralSegmenter or None, got {self.segmenter!r:.80}"
                )
            self.segmenter._validate_params()

    def _prepare(self, segmenter: SpectralSegmenter) -> None:
        """What the criterion of the seed's segmenter decides: the histograms' cell size, the
        tiles, and for ``nn`` the offsets and closeness of eq. 12's truncated field."""
        criterion = as_criterion(segmenter.criterion)
        self._criterion = criterion
        self._nn = criterion if isinstance(criterion, NearestNeighbour) else None
        self._resolution = self._nn.resolution if self._nn else HISTOGRAM_RESOLUTION
        self._tile_bits = max(0, int(math.floor(math.log2(self.tile / self._resolution))))
        self._field = None if self._nn is None else Closeness.of(self._nn)

    # ----------------------------------------------------------------------------- fitting
    def fit(self, keyframes: Sequence[Keyframe]) -> OnlineSegmenter:
        """Build the seed: the offline partition of ``keyframes`` (but those with no valid
        beam, skipped), its centres and ``T``.

        Raises
        ------
        SegmentationError
            No keyframe with a valid beam, a keyframe with a pose that is not finite, or a
            seed of a single cluster (``T`` needs two).
        """
        self._validate_params()
        keyframes = self._seeing(keyframes)
        self._fitted = False
        self.segmenter_ = segmenter = clone(self.segmenter or SpectralSegmenter())
        self._prepare(segmenter)
        scans = [self._scan(k, i) for i, k in enumerate(keyframes)]
        if not scans:
            raise SegmentationError(
                f"no keyframes to seed the online segmentation ({self.n_skipped_} with no "
                "valid beam skipped)"
            )
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
        self._index = CellIndex()
        self._tile_index: dict[int, set[int]] = {}
        self._seen_tiles: set[int] = set()
        self._cached: dict[int, CentreKeyframe] = {}
        self._heap: list[tuple[int, int]] = []

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

    # ----------------------------------------------------------------------------- queries
    @property
    def n_regions_(self) -> int:
        """Number of live regions."""
        self._check_fitted()
        return len(self.centres_)

    # ----------------------------------------------------------------------------- internals
    def _scan(
        self, keyframe: Keyframe, index: int
    ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
        """Cell keys, tile keys and points of a keyframe (one with a valid beam), or a
        SegmentationError."""
        points = self._points(keyframe, index)
        keys = cells_of(points, self._resolution)
        return keys, distinct(cell_keys(decode(keys) >> self._tile_bits)), points

    def _points(self, keyframe: Keyframe, index: int) -> NDArray[np.float64]:
        """The points keyframe ``index`` hit, or a SegmentationError if it is none or its pose
        is not finite."""
        if not isinstance(keyframe, Keyframe):
            raise SegmentationError(f"keyframe {index} is not a Keyframe: {keyframe!r}")
        if not np.all(np.isfinite(keyframe.pose)):
            raise SegmentationError(
                f"keyframe {index} (scan_index {keyframe.scan_index}) has a pose that is not "
                f"finite: {keyframe.pose}"
            )
        return keyframe.points()

    def _admit(self, keyframes: list[Keyframe]) -> None:
        """Refuse the batch if a keyframe is none, has a pose that is not finite, lies more
        than ``max_gap`` outside the bounding box of everything hit before it, or its dense
        regions would be larger than memory allows."""
        low, high = self._low, self._high
        for offset, keyframe in enumerate(keyframes):
            index = self._n + offset
            points = self._points(keyframe, index)
            x, y = keyframe.pose[:2]
            gap = max(low[0] - x, x - high[0], low[1] - y, y - high[1])
            if gap > self.max_gap:
                raise SegmentationError(
                    f"keyframe {index} (scan_index {keyframe.scan_index}) at ({x:.2f}, "
                    f"{y:.2f}) is {gap:.1f} m outside the map so far (max_gap {self.max_gap} m)"
                )
            low, high = np.minimum(low, points.min(axis=0)), np.maximum(high, points.max(axis=0))
        if self.regions_ is not None:
            self.regions_.check(keyframes)

    def _arrive(self, keyframe: Keyframe) -> int:
        index = self._n
        keys, tiles, points = self._scan(keyframe, index)
        candidates, distances = self._compare(keys, None, tiles, keyframe, None)
        best = int(np.argmin(distances)) if candidates else -1
        nearest = float(distances[best]) if candidates else 1.0
        if candidates and nearest <= self.theta * self.threshold_:
            region, move = candidates[best], True
        elif nearest >= self.threshold_:
            region, move = self._next_id, True
        else:
            region, move = candidates[best], False
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
        self._index.add(region, keys, np.ones(len(keys), np.int64))
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
        self._index.remove(b, keys)
        self._index.add(a, keys, hits)
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
        if self._field is not None:
            counts = np.ones(len(keys), np.int64) if weights is None else weights
            found, similarity = centre_similarities(
                self._field, self._index, self.centres_, keys, counts, own
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

    def _centre_keyframe(self, region: int) -> CentreKeyframe:
        """The centre as a keyframe (:meth:`~segmentation.centres.Centre.keyframe`), kept until
        the centre moves."""
        if region not in self._cached:
            self._cached[region] = self.centres_[region].keyframe(self._resolution)
        return self._cached[region]
