"""Errors raised by the topomap package (the facade, labels and names).

The roots of every branch live in the lowest package, :mod:`maps.errors`
(:class:`~maps.errors.TopomapError`), since imports only go downwards.
"""

from __future__ import annotations

import copy

from maps.errors import TopomapError


class LabelError(TopomapError, ValueError):
    """A classifier's output that cannot be used, or a name that is unknown or taken."""


class UsageError(TopomapError, ValueError):
    """Command-line options that do not go together or lie out of their range (the command
    line reports it like argparse does: one line, exit status 2)."""


class SchedulerError(TopomapError, ConnectionError):
    """A Dask scheduler address that is malformed or cannot be reached (``topomap batch
    --scheduler``)."""


class ExportError(TopomapError, ValueError):
    """An export that cannot be written as asked: an unknown storage or format, more data
    than the format's bound, or a writer that refuses the data (the cause is chained)."""


def led_by(err: TopomapError, message: str) -> TopomapError:
    """A copy of ``err`` (its type and fields) whose text is ``message``: an error from deep
    in the pipeline led by the input it came from.

    Examples
    --------
    >>> from segmentation.errors import SegmentationError
    >>> found = led_by(SegmentationError("no free space"), "lab.yaml: no free space")
    >>> type(found).__name__, str(found)
    ('SegmentationError', 'lab.yaml: no free space')
    """
    led = copy.copy(err)
    if isinstance(led, OSError):  # the file errors' text is their strerror
        led.strerror = message
    else:
        led.args = (message,)
    return led
