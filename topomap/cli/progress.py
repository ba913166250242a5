"""Progress on stderr for the command line: tqdm bars over items and timed stage lines.

The library never shows progress itself; it takes a ``progress`` callable (items in, items
out) or an ``on_stage`` callback, and the command line passes a :class:`Progress`.
"""

from __future__ import annotations

import sys
from collections.abc import Iterable, Iterator
from typing import IO, TypeVar

T = TypeVar("T")


class Progress:
    """Bars and stage lines on ``stream`` (stderr), or nothing at all when ``quiet``.

    Calling it wraps items in a tqdm bar (a plain count of the items when tqdm is not
    installed); :meth:`stage` announces a stage of work on a line of its own.

    Examples
    --------
    >>> import io
    >>> out = io.StringIO()
    >>> progress = Progress(stream=out)
    >>> progress.stage("counting")
    >>> sum(progress(range(3), "numbers"))
    3
    >>> out.getvalue().splitlines()[0]
    'counting ...'
    >>> quiet = io.StringIO()
    >>> list(Progress(quiet=True, stream=quiet)(range(3)))
    [0, 1, 2]
    >>> quiet.getvalue()
    ''
    """

    def __init__(self, *, quiet: bool = False, stream: IO[str] | None = None) -> None:
        self.quiet = quiet
        self.stream = sys.stderr if stream is None else stream

    def __call__(self, items: Iterable[T], desc: str | None = None) -> Iterator[T]:
        """``items`` one by one, with a bar that counts them."""
        if self.quiet:
            return iter(items)
        items = list(items)
        try:
            from tqdm import tqdm
        except ImportError:
            self.line(f"{desc or 'items'}: {len(items)}")
            return iter(items)
        return iter(tqdm(items, desc=desc, file=self.stream, leave=False, dynamic_ncols=True))

    def line(self, text: str) -> None:
        """One line of progress."""
        if not self.quiet:
            print(text, file=self.stream, flush=True)

    def stage(self, name: str) -> None:
        """``name ...``: a stage of work starts (bars of its own may follow)."""
        self.line(f"{name} ...")
