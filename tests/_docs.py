"""The figures the documentation states, read from its tables so that the tests assert what the docs say.

``docs/accuracy.md`` gives each figure with its test bound in brackets, ``0.16 (0.24)``; :func:`figure`
takes the figure (the first number of a cell) and the tests assert 1.5 x it, or tighter.
"""
from __future__ import annotations

import re
from pathlib import Path

DOCS = Path(__file__).resolve().parent.parent / "docs"
_NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")


def table(doc, *header):
    """The rows of the table in ``docs/<doc>`` whose header row starts with the cells ``header``.

    Returns ``{first cell: [the other cells]}`` in the table's order; raises ``LookupError`` when no
    table or more than one has that header (a table the tests read was renamed or removed).
    """
    lines = (DOCS / doc).read_text().splitlines()
    found = []
    for i, line in enumerate(lines):
        cells = _cells(line)
        if cells[: len(header)] == list(header) and i + 1 < len(lines) and set(lines[i + 1]) <= set("|-: "):
            rows = {}
            for row in lines[i + 2:]:
                if not row.startswith("|"):
                    break
                c = _cells(row)
                rows[c[0]] = c[1:]
            found.append(rows)
    if len(found) != 1:
        raise LookupError(f"docs/{doc}: {len(found)} tables with the header {header!r}, expected one")
    return found[0]


def figure(cell):
    """The figure of a cell: its first number (``"0.16 (0.24)"`` -> 0.16, ``"+0.52"`` -> 0.52)."""
    m = _NUMBER.search(cell)
    if m is None:
        raise ValueError(f"no number in the table cell {cell!r}")
    return float(m.group())


def figures(cell):
    """Every figure of a cell whose parts are separated by commas, each its first number
    (``"0.26 (0.39), 0.6 % (0.9)"`` -> [0.26, 0.6])."""
    return [figure(part) for part in cell.split(",")]


def _cells(line):
    line = line.strip()
    if not (line.startswith("|") and line.endswith("|")):
        return []
    return [c.strip() for c in line[1:-1].split("|")]
