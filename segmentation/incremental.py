"""Online segmentation on the offline engine: the robot's neighbourhood partitioned again as it
explores, the region ids carried over.

The offline pipeline (:class:`~segmentation.pipeline.MapSegmenter`) clusters a log's keyframes
on the paper's similarity weighed by the passages between their places. Online, the same
pipeline runs on what the robot has seen so far, around where it is:

1. **Arrival** (every keyframe). The keyframe claims the free cells it saw
   (:class:`~segmentation.online_regions.OnlineRegions`: the online map and its dense regions),
   its similarity to the ``neighbours`` earlier keyframes nearest to it is computed with the
   offline criterion and kept, and it joins the region of the one most like it (a new region
   when none is alike).
2. **Re-partition** (when the keyframes that arrived since the last one make ``renew`` of a
   window, 30 keyframes for a full window of 200). The ``window`` keyframes nearest to the robot
   are partitioned by the offline stages on the online map around them: conditioning, places,
   the spectral partition on the kept similarities weighed by the passages, the places voting
   (:meth:`~segmentation.pipeline.MapSegmenter.partition`). The inner part of the window (the
   ``inner`` share nearest to the robot, whose neighbourhood the window holds whole), but for
   the keyframes the last whole-map partition holds (below), takes the new partition under
   the ids it continues (:func:`~segmentation.growing.carry_ids`: a region kept, merged into
   the oldest id, split with the id on its larger piece, or new).
3. **Whole map** (each time the keyframes number ``whole`` times those of the last whole
   partition, the seed the first). Every keyframe is partitioned on the whole online map, as
   the offline pipeline would partition them (the online map has the cells of the offline
   one, and the similarity is the offline one over all pairs, not the pairs kept on
   arrival: with those, Freiburg 079's whole partition agreed with the offline one at ARI
   0.84, with all pairs 0.999), and all take the new partition under the ids they
   continue; the windows then give regions only to the keyframes that arrived since. What a
   window cannot see (a corridor system longer than a window, two rooms found to be one from
   far apart) is settled here.
   It runs in its own worker thread, beside the arrivals and the windows, and is taken when
   the next one starts (or at :meth:`~IncrementalSegmenter.flush`); on a geometric schedule
   its cost over a run is ``whole / (whole - 1)`` times that of one offline partition of the
   final keyframes. A window that puts :data:`UNITED_KEYFRAMES` or more keyframes of each of
   two settled regions in one cluster (a loop closed, a door found open), or as many of one
   settled region in each of two clusters (a door seen), is evidence the whole map's regions
   are out of date: the whole map is partitioned again out of turn once
   the keyframes number ``sqrt(whole)`` times those of the last whole partition (at most once
   between two in turn: the cost at most doubles; the one running is taken first, as in turn,
   so the same keyframes give the same regions however fast they come), or at
   :meth:`~IncrementalSegmenter.flush` if the run ends first.

An arrival costs what the window holds, not what the robot has seen. Every change is an
:class:`~segmentation.events.Event`: ``created``, ``grown``, ``split``, ``merged``, and
``moved`` for the keyframes a re-partition gave to another region (replaying the events from
the arrivals gives the regions now).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from maps.grid import OccupancyGrid
from maps.limits import RESOLUTION_RANGE, finite_in
from maps.mapping import MapBuilder
from maps.scan import Keyframe
from segmentation.affinity import standing_places
from segmentation.arrivals import KeptSimilarities, one_to_many
from segmentation.base import check_flags, check_lengths, clone, is_count
from segmentation.errors import ParameterError, SegmentationError
from segmentation.events import Event, OnlineEstimator, OnlineStateError
from segmentation.growing import carry_ids
from segmentation.online_regions import OnlineRegions
from segmentation.pipeline import MapSegmenter, by_place
from segmentation.similarity import ByFieldOfView, as_criterion

#: Keyframes of each of two settled regions a window puts in one cluster (or of one settled
#: region in each of two) before the whole map is partitioned again out of turn (2.5 m of
#: travel at the keyframes' 0.5 m: not a stray one).
UNITED_KEYFRAMES = 5

log = logging.getLogger(__name__)


@dataclass
class IncrementalSegmenter(OnlineEstimator):
    """Segment keyframes as they arrive with the offline pipeline (see the module docstring).

    Parameters
    ----------
    pipeline
        The offline pipeline whose stages and criterion are used.
    neighbours
        A keyframe's similarity is computed to this many earlier keyframes, nearest first.
    window
        Keyframes partitioned together.
    inner
        Share of the window (nearest to the robot) that takes the new partition.
    renew
        A re-partition when the keyframes arrived since the last make this share of a window
        (a young run, whose window is small, is re-partitioned more often, at no more cost).
    reach, region_resolution
        A keyframe claims the free cells it saw up to ``reach`` metres away, in cells of
        ``region_resolution`` metres (the dense regions and their graph).
    resolution
        Cell size of the online map the windows are partitioned on (metres), built as
        :func:`~maps.mapping.grid_from_keyframes` builds the offline one.
    margin
        The map around a window reaches this many metres beyond its keyframes.
    max_gap
        A keyframe more than this many metres from every earlier one is refused.
    random_state
        Seed of the spectral partitions.
    churn_age
        A keyframe this many keyframes old counts in :attr:`late_changes_` when its region
        changes.
    whole
        The whole map is partitioned again each time the keyframes number this many times
        those of its last partition in turn (``0``: never, the windows alone), and out of
        turn when a window finds two settled regions to be one, or one to be two (see the
        module docstring).
    background
        Run each re-partition in a worker thread beside the arrivals; its keyframes take
        their new regions when the next one of its kind starts or at :meth:`flush` (the same
        keyframes for the same run, so the same regions). ``False``: at once, on the caller's
        thread.

    Attributes
    ----------
    pipeline_ : MapSegmenter
        The copy of ``pipeline`` the run uses (fit clones it; the one given is never changed).
    labels_, arrival_labels_ : ndarray of int
        Region of every keyframe now, and when it arrived.
    events_ : list of Event
    n_seed_ : int
    late_changes_ : ndarray of int
        Per keyframe, how often its region changed once it was ``churn_age`` keyframes old.
    repartition_seconds_ : ndarray of float
        CPU time of each re-partition taken so far.

    Examples
    --------
    >>> import maps
    >>> plan = maps.generate_floor_plan("flat", random_state=0)
    >>> route = maps.wander(plan.grid, plan.labels, random_state=0)
    >>> scans = maps.simulate_scans(plan.grid, route.poses, maps.LaserModel(), random_state=0)
    >>> keyframes = maps.select_keyframes(scans)
    >>> online = IncrementalSegmenter().fit(keyframes[:40])
    >>> regions = online.partial_fit(keyframes[40:])
    >>> len(online.labels_) == len(keyframes), online.n_regions_ > 1
    (True, True)
    """

    pipeline: MapSegmenter = field(default_factory=MapSegmenter)
    neighbours: int = 12
    window: int = 200
    inner: float = 0.6
    renew: float = 0.15
    reach: float = 4.0
    region_resolution: float = 0.2
    resolution: float = 0.05
    margin: float = 8.0
    max_gap: float = 10.0
    random_state: int = 0
    churn_age: int = 50
    whole: float = 1.25
    background: bool = True
    pipeline_: MapSegmenter = field(init=False, repr=False)
    events_: list[Event] = field(init=False, repr=False)
    n_seed_: int = field(init=False, repr=False)
    regions_: OnlineRegions = field(init=False, repr=False)

    def _validate_params(self) -> None:
        for name, low in (("neighbours", 1), ("window", 2), ("churn_age", 0)):
            value = getattr(self, name)
            if not is_count(value) or value < low:
                raise ParameterError(f"{name} must be an integer >= {low}, got {value!r}")
        check_flags(self, "background")
        for name in ("inner", "renew"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and 0 < value <= 1):
                raise ParameterError(f"{name} must lie in (0, 1], got {value!r}")
        whole = self.whole
        if not (isinstance(whole, int | float) and (whole == 0 or 1 < whole < np.inf)):
            raise ParameterError(f"whole must be 0 or a finite number > 1, got {whole!r}")
        check_lengths(self, "reach", "margin", "max_gap")
        for name in ("region_resolution", "resolution"):
            problem = finite_in(getattr(self, name), name, *RESOLUTION_RANGE, unit="m per cell")
            if problem is not None:
                raise ParameterError(problem)
        if not isinstance(self.pipeline, MapSegmenter):
            raise ParameterError(f"pipeline must be a MapSegmenter, got {self.pipeline!r}")
        self.pipeline._validate_params()

    # ----------------------------------------------------------------------------- fitting
    def fit(self, keyframes: Sequence[Keyframe]) -> IncrementalSegmenter:
        """Seed: the offline partition of ``keyframes`` (all of them, one window, but those
        with no valid beam, skipped).

        Raises
        ------
        ParameterError
            A parameter out of range (checked here, not when the segmenter is made).
        SegmentationError
            Fewer than two keyframes with a valid beam, or one with a pose that is not finite.
        """
        self._validate_params()
        keyframes = self._seeing(keyframes)
        if len(keyframes) < 2:
            raise SegmentationError(
                f"{len(keyframes)} keyframe(s) with a valid beam cannot seed "
                f"({self.n_skipped_} with none skipped): give two or more"
            )
        self._fitted = False
        for previous in (getattr(self, "_pending", None), getattr(self, "_whole", None)):
            if previous is not None and previous.worker is not None:
                previous.worker.join()  # a re-partition of the previous run: dropped
        self._pending: _Pending | None = None
        self._whole: _Pending | None = None
        self._owed = False  # a window found two settled regions one, or one two
        self._work: list[float] = []
        self.pipeline_ = clone(self.pipeline)
        self._criterion = as_criterion(self.pipeline_.spectral.criterion)
        self._one = one_to_many(self._criterion)
        self._keyframes: list[Keyframe] = []
        self._n = 0
        self._index: dict[int, int] = {}
        self._rows: list[dict[int, float]] = []
        self._poses = np.zeros((max(64, 2 * len(keyframes)), 2))
        self._labels = np.zeros(len(self._poses), np.int64)
        self._arrival = np.zeros_like(self._labels)
        self._late = np.zeros_like(self._labels)
        self.regions_ = OnlineRegions(self.region_resolution, self.reach)
        self._map = MapBuilder(self.resolution)
        self.events_ = []
        self._next_id = 1
        for keyframe in keyframes:
            self._check(keyframe, self._n)
            self._add(keyframe, self._similar(keyframe, self._distance(keyframe)), 1)
        self._start(np.arange(len(keyframes)), len(keyframes), whole=True, seeding=True)
        self._arrival[: len(keyframes)] = self._labels[: len(keyframes)]
        self.n_seed_ = self._whole_at = self._last_whole = self._settled = len(keyframes)
        self._since = 0
        self._fitted = True
        return self

    # ----------------------------------------------------------------------------- queries
    @property
    def late_changes_(self) -> NDArray[np.int64]:
        """Per keyframe, how often its region changed after it was ``churn_age`` keyframes
        old."""
        self._check_fitted()
        return self._late[: self._n].copy()

    @property
    def n_regions_(self) -> int:
        """Number of live regions."""
        return len(np.unique(self.labels_))

    @property
    def repartition_seconds_(self) -> NDArray[np.float64]:
        """CPU time of each re-partition taken so far (the seed's first), on the thread
        that ran it."""
        self._check_fitted()
        return np.array(self._work)

    # ----------------------------------------------------------------------------- internals
    def _check(self, keyframe: Keyframe, index: int) -> None:
        """A SegmentationError if keyframe ``index`` is none or its pose is not finite."""
        if not isinstance(keyframe, Keyframe):
            raise SegmentationError(f"keyframe {index} is not a Keyframe: {keyframe!r}")
        if not np.all(np.isfinite(keyframe.pose)):
            raise SegmentationError(f"keyframe {index} has a pose that is not finite")

    def _distance(self, keyframe: Keyframe) -> NDArray[np.float64]:
        """The keyframe's distance to every earlier one."""
        return np.hypot(*(self._poses[: self._n] - keyframe.pose[:2]).T)

    def _similar(self, keyframe: Keyframe, distance: NDArray[np.float64]) -> dict[int, float]:
        """The keyframe's similarity to the ``neighbours`` earlier keyframes nearest to it
        (at ``distance``; those with none left out)."""
        count = min(self.neighbours, len(distance))
        if count == 0:
            return {}
        near = np.argpartition(distance, count - 1)[:count]
        keyframes = [keyframe, *(self._keyframes[i] for i in near.tolist())]
        criterion = self._criterion
        if isinstance(criterion, ByFieldOfView):
            criterion = criterion.chosen(keyframes)
        if self._one is not None and criterion == self._one.criterion:
            values = self._one.similarities(keyframe, near.tolist())
        else:
            values = criterion.affinity(keyframes)[0].toarray().ravel()[1:]
        return {int(i): float(v) for i, v in zip(near, values, strict=True) if v > 0}

    def _add(self, keyframe: Keyframe, row: dict[int, float], region: int) -> None:
        """Keep the keyframe in ``region``, its similarities ``row`` and its claims."""
        index = len(self._keyframes)
        if index >= len(self._poses):
            for name in ("_poses", "_labels", "_arrival", "_late"):
                array = getattr(self, name)
                setattr(self, name, np.concatenate([array, np.zeros_like(array)]))
        self._poses[index] = keyframe.pose[:2]
        self._keyframes.append(keyframe)
        self._n = len(self._keyframes)
        if self._one is not None:
            self._one.keep(keyframe)
        self._index[id(keyframe)] = index
        self._rows.append(row)
        self._labels[index] = self._arrival[index] = region
        self.regions_.add(index, keyframe, region)
        self._map.add(keyframe)

    def _admit(self, keyframes: list[Keyframe]) -> None:
        """Refuse the batch if a keyframe is none, has a pose that is not finite, lies more
        than ``max_gap`` from every keyframe before it, or its map or dense regions would be
        larger than memory allows."""
        for offset, keyframe in enumerate(keyframes):
            self._check(keyframe, self._n + offset)
        poses = np.vstack([self._poses[: self._n], *(k.pose[:2] for k in keyframes)])
        for index in range(self._n, len(poses)):
            gap = np.hypot(*(poses[:index] - poses[index]).T).min()
            if gap > self.max_gap:
                keyframe = keyframes[index - self._n]
                raise SegmentationError(
                    f"keyframe {index} (scan_index {keyframe.scan_index}) is {gap:.1f} m from "
                    f"every earlier keyframe (max_gap {self.max_gap} m)"
                )
        self.regions_.check(keyframes)
        self._map.check(keyframes)

    def _arrive(self, keyframe: Keyframe) -> int:
        index = self._n
        distance = self._distance(keyframe)
        row = self._similar(keyframe, distance)
        if row:
            region = int(self._labels[max(row, key=row.__getitem__)])
            self.events_.append(Event("grown", index, region))
        else:
            region = self._new_id()
            self.events_.append(Event("created", index, region))
        self._add(keyframe, row, region)
        if self.whole and self._n >= self.whole * self._whole_at:
            self._whole_at = self._n
            self._repartition_whole()
        self._since += 1
        if self._since >= self.renew * min(self.window, index + 1):
            self._since = 0
            size = min(self.window, index + 1)
            nearest = np.argsort(np.append(distance, 0.0), kind="stable")[:size]
            self._take(self._pending)
            self._pending = self._start(nearest, max(1, round(self.inner * size)))
        if self._owed and self._n >= self.whole**0.5 * self._last_whole:
            self._repartition_whole()  # out of turn: at most once between two in turn
        return int(self._labels[index])

    def _repartition_whole(self) -> None:
        """Take the whole map's re-partition under way and start the next on every keyframe."""
        self._take(self._whole)
        self._last_whole, self._owed = self._n, False
        self._whole = self._start(np.arange(self._n), self._n, whole=True)

    def _new_id(self) -> int:
        self._next_id += 1
        return self._next_id - 1

    def _start(
        self, window: NDArray[np.int64], take: int, whole: bool = False, seeding: bool = False
    ) -> _Pending | None:
        """Partition the keyframes ``window`` (nearest to the robot first) for the first
        ``take`` of them to take the new regions under the ids they continue: at once when
        seeding or without ``background``, else in a worker thread (returned, for
        :meth:`_take`). The map is a snapshot (the arrivals beside it do not change it), of
        the window with ``margin`` around, or all of it for a ``whole`` partition."""
        keyframes = [self._keyframes[i] for i in window.tolist()]
        poses = self._poses[window]
        low, high = poses.min(axis=0) - self.margin, poses.max(axis=0) + self.margin
        if whole:  # every keyframe on the whole map, as offline
            low = high = None
        pending = _Pending(window, take, self._n, self._map.snapshot(), whole)
        kept = KeptSimilarities(self._rows, self._index)  # lists that only grow
        pipeline = self.pipeline_

        def work() -> None:
            clock = time.thread_time()
            try:
                grid = pending.map.grid(low, high)
                similarity = None if whole else kept  # the whole map's: all pairs, as offline
                pending.found = self._partition(pipeline, similarity, keyframes, poses, grid)
            except BaseException as err:  # a bug: raised again on the caller's thread
                pending.error = err
            pending.seconds = time.thread_time() - clock

        if seeding or not self.background:
            work()
            if seeding:
                self._finish(pending, seeding=True)
            else:
                self._take(pending)
            return None
        # not a daemon: the interpreter waits for it at exit (native code of a daemon thread
        # still running when the interpreter is torn down aborts the process)
        pending.worker = threading.Thread(target=work, name="repartition")
        pending.worker.start()
        return pending

    def _take(self, pending: _Pending | None) -> None:
        """Wait for the re-partition ``pending`` (if any) and give its keyframes their new
        regions; the keyframes that arrived beside a window join again, those that arrived
        beside the whole map's follow its merges."""
        if pending is None:
            return
        if pending.worker is not None:
            pending.worker.join()
        before = self._labels[: pending.arrived].copy() if pending.whole else None
        self._finish(pending, settled=0 if pending.whole else self._settled)
        if pending.found is None:
            return
        if before is not None:
            self._settled = pending.arrived
            self._follow(pending.arrived, before)
        else:
            self._replay(max(pending.arrived, self._settled))

    def _finish(self, pending: _Pending, seeding: bool = False, settled: int = 0) -> None:
        if pending.error is not None:
            raise pending.error
        self._work.append(pending.seconds)
        self._carry(pending.window[: pending.take], pending.found, seeding, settled)

    def flush(self) -> None:
        """Wait for the re-partitions under way and give their keyframes their new regions,
        the one that started later last (the whole map's last of two started together: it
        saw as much and more); :attr:`labels_` then holds every re-partition started so
        far."""
        if not hasattr(self, "_owed"):
            raise OnlineStateError("flush before fit: fit the seed keyframes first")
        whole, self._whole = getattr(self, "_whole", None), None
        pending, self._pending = getattr(self, "_pending", None), None
        if whole is not None and pending is not None and whole.arrived < pending.arrived:
            whole, pending = pending, whole
        self._take(pending)
        self._take(whole)
        if self._owed and self.whole:  # what a robot going on would have run by now
            self._repartition_whole()
            self._take(self._whole)
            self._whole = None

    def _replay(self, first: int) -> None:
        """The keyframes from ``first`` on, which arrived while a re-partition ran, join
        again in order the region of the earlier keyframe most like them: the regions they
        would have joined had it been taken at once."""
        labels = self._labels[: self._n].copy()
        for index in range(first, self._n):
            row = self._rows[index]
            if row:  # a keyframe like none before it keeps the region it started
                labels[index] = labels[max(row, key=row.__getitem__)]
        self._apply(np.arange(first, self._n), labels[first:], [], seeding=False)

    def _follow(self, first: int, before: NDArray[np.int64]) -> None:
        """The keyframes from ``first`` on keep their regions (the windows gave them), but
        for those whose region the re-partition of the earlier ones (``before`` it) took
        away: they follow it into the region that took most of it."""
        now = self._labels[:first]
        labels = self._labels[first : self._n].copy()
        for gone in set(np.unique(labels).tolist()) - set(np.unique(now).tolist()):
            was = before == gone
            if was.any():
                labels[labels == gone] = np.bincount(now[was]).argmax()
        self._apply(np.arange(first, self._n), labels, [], seeding=False)

    def _partition(
        self,
        pipeline: MapSegmenter,
        kept: KeptSimilarities | None,
        keyframes: list[Keyframe],
        poses: NDArray[np.float64],
        grid: OccupancyGrid,
    ) -> NDArray[np.int64] | None:
        """``pipeline``'s stages on ``grid`` (the online map around ``keyframes``, at
        ``poses``, their similarities ``kept``): the cluster of each keyframe, or ``None`` when
        too little is seen yet. Reads nothing a later keyframe changes: it may run beside the
        arrivals."""
        try:
            _, space, places = pipeline.places(pipeline.condition(grid))
            spectral = replace(pipeline.spectral, random_state=self.random_state)
            if kept is not None:
                spectral = replace(spectral, criterion=kept)
            fitted = pipeline.partition(space, places, keyframes, spectral)
        except SegmentationError as err:  # too little seen yet: keep the regions as they are
            log.info("re-partition of %d keyframes skipped: %s", len(keyframes), err)
            return None
        rows, cols = space.world_to_cell(poses[:, 0], poses[:, 1])
        voted = by_place(places, standing_places(space, places, poses), fitted.labels_)
        inside = space.contains(rows, cols)
        found = fitted.labels_ + 1
        found[inside] = np.where(
            voted[rows[inside], cols[inside]] > 0, voted[rows[inside], cols[inside]], found[inside]
        )
        return found.astype(np.int64)

    def _carry(
        self,
        inner: NDArray[np.int64],
        found: NDArray[np.int64] | None,
        seeding: bool,
        settled: int = 0,
    ) -> None:
        """The keyframes ``inner`` take the clusters ``found`` (the first of them) under the
        ids they continue, but for those before ``settled`` (nothing found: the seed is one
        region)."""
        if found is None:
            if seeding:
                self._labels[inner] = self._new_id()
            return
        new = found[: len(inner)]
        old = np.zeros_like(new) if seeding else self._labels[inner]
        carried = carry_ids(old.reshape(1, -1), new.reshape(1, -1), self._next_id)
        self._next_id = carried.next_id
        labels = carried.labels.ravel().astype(np.int64)
        events = carried.events
        if settled:  # the keyframes of the last whole-map partition keep its regions
            before, after = old[inner < settled], new[inner < settled]
            # two settled regions in one cluster, or (the other way round) one in two
            self._owed |= bool(self.whole) and (_unites(before, after) or _unites(after, before))
            fresh = inner >= settled
            inner, labels = inner[fresh], labels[fresh]
            given = set(labels.tolist())
            events = [e for e in events if e["event"] == "removed" or e["region"] in given]
        self._apply(inner, labels, events, seeding)

    def _apply(
        self, inner: NDArray[np.int64], labels: NDArray[np.int64], events: list, seeding: bool
    ) -> None:
        index = len(self._keyframes) - 1
        before = self._labels[inner].copy()
        changed = before != labels
        old_ids = set(before.tolist())
        self._labels[inner] = labels
        if not seeding:
            old_enough = inner < index - self.churn_age
            self._late[inner[changed & old_enough]] += 1
        self.regions_.relabel(inner, labels)
        live = set(np.unique(self._labels[: index + 1]).tolist())
        for event in events:
            kind, region = event["event"], event["region"]
            if kind == "created" or (seeding and kind != "removed"):
                self.events_.append(Event("created", index, region))
            elif kind == "split":
                self.events_.append(Event("split", index, region, source=event["source"]))
        if not seeding:
            pairs = np.unique(np.column_stack([before[changed], labels[changed]]), axis=0)
            for source, target in pairs.tolist():
                members = inner[changed & (before == source) & (labels == target)]
                self.events_.append(
                    Event("moved", index, target, source=source, members=tuple(members.tolist()))
                )
        for gone in sorted(old_ids - live - {0}):
            taken = labels[before == gone]
            survivor = int(np.bincount(taken).argmax()) if len(taken) else 0
            self.events_.append(Event("merged", index, survivor, absorbed=gone))


@dataclass
class _Pending:
    """A re-partition under way: its window, how many of them take its result, the first
    keyframe that arrived beside it, the map it reads, whether it is the whole map's, its
    worker (none when run at once), what it found (or raised) and its CPU time."""

    window: NDArray[np.int64]
    take: int
    arrived: int
    map: MapBuilder
    whole: bool
    worker: threading.Thread | None = None
    found: NDArray[np.int64] | None = None
    error: BaseException | None = None
    seconds: float = 0.0


def _unites(old: NDArray[np.int64], new: NDArray[np.int64]) -> bool:
    """Whether one cluster of ``new`` holds :data:`UNITED_KEYFRAMES` keyframes or more of each
    of two regions of ``old`` (the same keyframes): evidence the regions are one.

    Examples
    --------
    >>> old = np.array([1] * 6 + [2] * 6)
    >>> _unites(old, np.ones(12, np.int64)), _unites(old, old + 10)
    (True, False)
    """
    pairs, counts = np.unique(np.column_stack([new, old]), axis=0, return_counts=True)
    held = pairs[counts >= UNITED_KEYFRAMES, 0]
    return len(held) > len(np.unique(held))
