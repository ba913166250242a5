"""What both online engines share: the events they record (``events_``, ``events.jsonl``) and
the queries they answer once fitted (:class:`OnlineEstimator`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any, Literal

import networkx as nx
import numpy as np
from numpy.typing import NDArray

from maps.scan import Keyframe, keyframe_list, seeing
from segmentation.base import Estimator
from segmentation.errors import SegmentationError
from segmentation.online_regions import OnlineRegions


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


class OnlineEstimator(Estimator):
    """The queries of a fitted online engine: the region of every keyframe now and on arrival,
    the dense regions at a point and their graph. Engines keep ``_labels`` and ``_arrival``
    (grown as keyframes arrive), ``_n`` (keyframes so far), ``regions_`` and ``_fitted``.

    A keyframe whose scan has no valid beam saw nothing: as offline, it is skipped (in the
    seed and when it arrives), counted in ``n_skipped_``, and every other keyframe gets the
    region it would get without it.
    """

    _labels: NDArray[np.int64]
    _arrival: NDArray[np.int64]
    _n: int
    regions_: OnlineRegions | None
    n_skipped_: int

    def _seeing(self, keyframes: Sequence[Keyframe]) -> list[Keyframe]:
        """The seed ``keyframes`` (:func:`~maps.scan.keyframe_list`) but those with no valid
        beam, which ``n_skipped_`` counts from here on."""
        keyframes = keyframe_list(keyframes)
        seen = seeing(keyframes)
        self.n_skipped_ = len(keyframes) - len(seen)
        return seen

    def partial_fit(self, keyframes: Keyframe | Sequence[Keyframe]) -> int | list[int]:
        """Assign one keyframe (returns its region) or a batch (returns a list), in order; a
        keyframe with no valid beam is skipped (its region 0).

        Raises
        ------
        OnlineStateError
            Before ``fit``.
        SegmentationError
            A keyframe with a pose that is not finite, or one too far from everything seen
            before it (``max_gap``).
        MapTooLargeError
            A keyframe whose map would be larger than memory allows.

        A refused call leaves the segmenter as it was before it (every keyframe is checked
        before the first is assigned): the keyframes offered again without the bad ones give
        the regions of a run that never saw them.
        """
        if not getattr(self, "_fitted", False):
            raise OnlineStateError("partial_fit before fit: fit the seed keyframes first")
        batch: Sequence[Keyframe]
        if isinstance(keyframes, Keyframe):
            batch = [keyframes]
        elif isinstance(keyframes, Sequence):  # each keyframe is checked below
            batch = keyframes
        else:
            raise SegmentationError(
                f"partial_fit takes a Keyframe or a list of them, got {keyframes!r:.200}"
            )
        blind = [isinstance(k, Keyframe) and not seeing([k]) for k in batch]
        self._admit([k for k, skipped in zip(batch, blind, strict=True) if not skipped])
        regions = [
            0 if skipped else self._arrive(k) for k, skipped in zip(batch, blind, strict=True)
        ]
        self.n_skipped_ += sum(blind)
        return regions[0] if isinstance(keyframes, Keyframe) else regions

    def _admit(self, keyframes: list[Keyframe]) -> None:
        """Refuse ``keyframes`` (each with a valid beam, to arrive in order) if one of them
        would be refused, before anything changes."""
        raise NotImplementedError

    def _arrive(self, keyframe: Keyframe) -> int:
        """Assign an admitted keyframe (:meth:`_admit`); its region."""
        raise NotImplementedError

    def flush(self) -> None:
        """Finish the work under way beside the arrivals (nothing to finish for an engine that
        does all of it on arrival)."""

    @property
    def labels_(self) -> NDArray[np.int64]:
        """Region of every keyframe so far but those skipped (a merged id is replaced)."""
        self._check_fitted()
        return self._labels[: self._n].copy()

    @property
    def arrival_labels_(self) -> NDArray[np.int64]:
        """Region each keyframe was given when it arrived."""
        self._check_fitted()
        return self._arrival[: self._n].copy()

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
