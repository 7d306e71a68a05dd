"""Text read from a file is data (issue 36, docs/security.md): the domain of a name, and the one way such text is
shown on a terminal.

A leaf like :mod:`tendyn.errors`: every package may import it, it imports nothing of tendyn.

* :func:`name_problem` — why a string is not a name (the domain of every ``name`` field of a device file:
  printable characters only, no control character, no newline, at most :data:`NAME_MAX_CHARS`).
* :func:`text_problem` — why a free text (a ``description``) is not one: no control character but newline and
  tab, at most :data:`TEXT_MAX_CHARS`.
* :func:`spreadsheet_cell` — a text cell of a CSV file that a spreadsheet would run as a formula, quoted.
* :func:`printable` — a text for the terminal: every control character (C0, DEL, C1, the bidirectional
  overrides) shown as its escape (``\\x1b``, ``\\u202e``) instead of being sent to the terminal, which would run it
  (retitle, clear, move the cursor, reorder the line).
"""

from __future__ import annotations

__all__ = ["FORMULA_START", "NAME_MAX_CHARS", "TEXT_MAX_CHARS", "name_problem", "printable", "spreadsheet_cell",
           "text_problem"]

NAME_MAX_CHARS = 200
"""Longest name [characters] (a device, joint, frame, transmission, drive, actuator or term name)."""

TEXT_MAX_CHARS = 10_000
"""Longest free text [characters] (a device's ``description``)."""

NAME_DOMAIN = f"printable characters only (no control character, no newline), 1 to {NAME_MAX_CHARS} characters"
"""The domain of a name, as the messages and docs/device-file.md say it."""

_BIDI = set(range(0x202A, 0x202F)) | set(range(0x2066, 0x206A)) | {0x200E, 0x200F, 0x061C}
"""Bidirectional marks, embeddings, overrides and isolates: they reorder what a terminal or editor shows."""


def _control(c: str, keep: str = "") -> bool:
    o = ord(c)
    return c not in keep and (o < 0x20 or 0x7F <= o <= 0x9F or o in _BIDI)


def _escape(c: str) -> str:
    o = ord(c)
    return f"\\x{o:02x}" if o <= 0xFF else f"\\u{o:04x}"


def _short(text: str, n: int = 40) -> str:
    """The start of a text as a Python literal (control characters escaped), for a one-line message."""
    return repr(text if len(text) <= n else text[:n] + "…")


def name_problem(text: str) -> str | None:
    """Why ``text`` is not a name (None if it is one): see :data:`NAME_DOMAIN`."""
    if not text.strip():
        return "must not be empty"
    if len(text) > NAME_MAX_CHARS:
        return f"has {len(text)} characters, at most {NAME_MAX_CHARS} allowed (got {_short(text)})"
    bad = next((k for k, c in enumerate(text) if not c.isprintable() or _control(c)), None)
    if bad is not None:
        return (f"must be {NAME_DOMAIN}: character {bad + 1} is {_escape(text[bad])!s} "
                f"(got {_short(text)})")
    return None


def text_problem(text: str) -> str | None:
    """Why ``text`` is not a free text (None if it is one): no control character but newline and tab, at most
    :data:`TEXT_MAX_CHARS` characters."""
    if len(text) > TEXT_MAX_CHARS:
        return f"has {len(text)} characters, at most {TEXT_MAX_CHARS} allowed"
    bad = next((k for k, c in enumerate(text) if _control(c, "\n\t")), None)
    if bad is not None:
        return (f"must be text without control characters (newline and tab allowed): character {bad + 1} is "
                f"{_escape(text[bad])} (got {_short(text)})")
    return None


def printable(text, keep: str = "\n\t") -> str:
    """``text`` (any object, as ``str``) for a terminal: each control character but those in ``keep`` shown as
    its escape (``"\\x1b]0;x\\x07"`` → ``"\\\\x1b]0;x\\\\x07"``); everything else unchanged."""
    s = str(text)
    if all(not _control(c, keep) for c in s):       # the usual case: nothing to do
        return s
    return "".join(_escape(c) if _control(c, keep) else c for c in s)


FORMULA_START = ("=", "+", "-", "@", "\t", "\r")
"""First characters that make a spreadsheet read a CSV cell as a formula (OWASP: CSV injection)."""


def spreadsheet_cell(value):
    """A CSV cell: a text starting with one of :data:`FORMULA_START` gets a leading ``'`` (the spreadsheets' mark
    of a text cell), so opening the file runs nothing; any other value (numbers too) unchanged. A reader gets the
    text back by dropping a leading ``'`` before one of :data:`FORMULA_START`."""
    if isinstance(value, str) and value.startswith(FORMULA_START):
        return "'" + value
    return value
