"""Exceptions a user can cause, shared by the packages and the command line.

The command line maps them to exit codes: :class:`UsageError` (and the file errors
``DeviceError``, ``LogError``) → 2, :class:`CheckFailed` → 1, anything else → 3.
"""

from __future__ import annotations


class UsageError(ValueError):
    """A bad option or argument value, named as the user wrote it.

    Parameters
    ----------
    problem : str
        What is wrong, e.g. ``"must be 1…4 (got 0)"``.
    option : str or None
        The option's Python name (``"control_rate"``); shown as its flag (``--control-rate``).
    """

    def __init__(self, problem: str, option: str | None = None):
        self.option = option
        self.problem = problem
        super().__init__(f"{flag(option)}: {problem}" if option else problem)


class CheckFailed(RuntimeError):
    """A computed result failed a check it must pass (a diverged run, a fit outside its bound)."""


def flag(option: str) -> str:
    """``control_rate`` → ``--control-rate``; positional names (``device``) are kept."""
    return option if option in POSITIONALS else "--" + option.replace("_", "-")


POSITIONALS = ("device", "experiment", "command", "action")
