"""Errors raised by segmentation: each names the bad value."""

from __future__ import annotations


class SegmentationError(ValueError):
    """Input that cannot be segmented: empty keyframes, NaN poses, a map with no free cell."""


class ParameterError(ValueError):
    """A parameter out of its range, e.g. ``k`` larger than the number of keyframes."""


class ExportFormatError(ValueError):
    """A region or graph file that cannot be read back: names the file and the field."""
