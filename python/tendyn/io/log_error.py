"""The one error of experiment logs: :class:`LogError`, whose message names the file, the column, the row
(and the CSV line) of a problem."""

from __future__ import annotations

class LogError(ValueError):
    """A log (file or in memory) is invalid, or cannot be written.

    The message names the file, the column and the row when relevant, e.g.
    ``run.csv: column q_motor_2, row 17 (line 20, time 0.017 s): value nan is not finite``.

    Attributes
    ----------
    file : str or None
        The file (or ``"<memory>"``) the error is about.
    column : str or None
        The column name (or ``meta.<key>`` for a meta entry).
    row : int or None
        0-based sample index of the first bad row.
    line : int or None
        1-based line number in a CSV file.
    problem : str
        What is wrong, without the location prefix.
    """

    def __init__(self, problem: str, *, file=None, column: str | None = None, row: int | None = None,
                 line: int | None = None, time: float | None = None):
        self.file = None if file is None else str(file)
        self.column = column
        self.row = row
        self.line = line
        self.problem = problem
        where = []
        if column is not None:
            where.append(column if column.startswith("meta") else f"column {column}")
        extra = []
        if line is not None:
            extra.append(f"line {line}")
        if time is not None:
            extra.append(f"time {time!r} s")
        if row is not None:
            where.append(f"row {row}" + (f" ({', '.join(extra)})" if extra else ""))
        elif extra:
            where.append(", ".join(extra))
        head = ", ".join(where)
        parts = [p for p in (self.file, head) if p]
        super().__init__(": ".join(parts + [problem]))
