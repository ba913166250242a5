"""Errors raised by segmentation: each names the bad value."""

from __future__ import annotations

from maps.errors import TopomapError


class SegmentationError(TopomapError, ValueError):
    """Base class of every error raised by :mod:`segmentation`; raised itself for input that
    cannot be segmented: empty keyframes, NaN poses, a map with no free cell."""


class ParameterError(SegmentationError):
    """A parameter out of its range, e.g. ``k`` larger than the number of keyframes."""


class NotFittedError(SegmentationError, AttributeError):
    """A fitted attribute (a name ending in ``_``) read before ``fit``; an ``AttributeError``
    too, as scikit-learn's is, so ``hasattr(model, "labels_")`` still says whether it is
    fitted."""


class ExportFormatError(SegmentationError):
    """A region or graph file that cannot be read back: names the file and the field."""


class RegionNotFoundError(SegmentationError, LookupError):
    """A region id or name the region graph does not have: names the query, lists the
    known names and suggests the closest."""
