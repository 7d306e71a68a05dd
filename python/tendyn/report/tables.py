"""Text tables (:func:`tendyn.results.format_table`, what every ``Result.table()`` prints) read back into cells,
so a report shows them as HTML tables. Computes nothing: it only re-cuts text along the columns of the rule line.

A table of ``format_table`` is an optional title line, a header line, a rule of dashes (one run per column,
runs separated by two spaces) and rows right-aligned to exactly the rule's width. Any other line is kept as
preformatted text.
"""

from __future__ import annotations

import re
from typing import Any, Sequence

__all__ = ["Table", "split_text"]

_RULE = re.compile(r"^-+(  -+)*$")


class Table:
    """One table of a report: ``headers`` (list of str), ``rows`` (list of lists of cells) and a ``title``.

    Cells are shown as given (floats as ``%.4g``, like :func:`tendyn.results.format_table`)."""

    kind = "table"

    def __init__(self, headers: Sequence[str], rows: Sequence[Sequence[Any]], title: str = ""):
        self.headers = [str(h) for h in headers]
        self.rows = [[_cell(v) for v in r] for r in rows]
        self.title = title

    def to_dict(self) -> dict:
        return {"title": self.title, "headers": self.headers, "rows": self.rows}


class Text:
    """Preformatted text of a report (a block of ``Result.table()`` that is not a table)."""

    kind = "text"

    def __init__(self, text: str):
        self.text = text


def _cell(v) -> str:
    if isinstance(v, float) or type(v).__name__.startswith("float"):
        return f"{float(v):.4g}"
    return "" if v is None else str(v)


def _spans(rule: str) -> list[tuple[int, int]]:
    return [(m.start(), m.end()) for m in re.finditer(r"-+", rule)]


def _fits(line: str, spans) -> bool:
    """A line laid out on the rule's columns: same width, spaces in the gaps."""
    if len(line) != spans[-1][1]:
        return False
    return all(line[a:b] == "  " for (_, a), (b, _) in zip(spans[:-1], spans[1:]))


def _cut(line: str, spans) -> list[str]:
    return [line[a:b].strip() for a, b in spans]


def split_text(text: str) -> list:
    """The blocks of a text: :class:`Table` for each table of ``format_table``, :class:`Text` for the rest."""
    lines = text.splitlines()
    blocks: list = []
    free: list[str] = []
    i = 0

    def flush(upto: list[str]):
        body = "\n".join(upto).strip("\n")
        if body.strip():
            blocks.append(Text(body))

    while i < len(lines):
        line = lines[i]
        if _RULE.match(line) and i >= 1 and _fits(lines[i - 1], _spans(line)):
            spans = _spans(line)
            header = free.pop()                   # the line before the rule
            title = ""
            if free and free[-1].strip() and not _fits(free[-1], spans):
                title = free.pop()
            flush(free)
            free = []
            rows = []
            i += 1
            while (i < len(lines) and _fits(lines[i], spans) and not _RULE.match(lines[i])
                   and not (i + 1 < len(lines) and _RULE.match(lines[i + 1]))):   # the next table's header
                rows.append(_cut(lines[i], spans))
                i += 1
            blocks.append(Table(_cut(header, spans), rows, title.strip()))
            continue
        free.append(line)
        i += 1
    flush(free)
    return blocks
