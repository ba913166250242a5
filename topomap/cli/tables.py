"""The one markdown table writer of the tools (commands, benchmarks, reports)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any


def markdown_table(rows: Sequence[Mapping[str, Any]], columns: Sequence[str]) -> str:
    """A markdown table of ``rows`` restricted to ``columns``; a missing or None value is
    ``-``.

    Examples
    --------
    >>> rows = [{"map": "lab", "mcc": 0.9}, {"map": "flat", "mcc": None}]
    >>> print(markdown_table(rows, ["map", "mcc"]))
    | map | mcc |
    |---|---|
    | lab | 0.9 |
    | flat | - |
    """
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    for row in rows:
        cells = ["-" if row.get(c) is None else str(row[c]) for c in columns]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)
