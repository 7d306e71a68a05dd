"""Progress on stderr: a bar with ETA (tqdm) when stderr is a terminal, one line per step otherwise (logs, CI,
pipes). One place decides, so every command shows progress the same way.

Examples
--------
>>> import io
>>> err = io.StringIO()
>>> with Steps(2, "claims", stream=err) as steps:
...     steps.step("C1")
...     steps.step("C2")
>>> print(err.getvalue().strip())
[claims] C1 (1/2) …
[claims] C2 (2/2) …
"""

from __future__ import annotations

import sys
from typing import TextIO


def is_terminal(stream: TextIO | None = None) -> bool:
    stream = sys.stderr if stream is None else stream
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


class Steps:
    """``total`` named steps of a command ``name``: :meth:`step` before each. On a terminal, a tqdm bar whose
    ETA comes from the steps done so far; elsewhere ``[name] label (i/total) …`` lines. ``quiet``: nothing."""

    def __init__(self, total: int, name: str, *, stream: TextIO | None = None, quiet: bool = False,
                 bar: bool | None = None):
        self.total, self.name, self.done = total, name, 0
        self.stream = sys.stderr if stream is None else stream
        self.quiet = quiet
        self._bar = None
        if not quiet and (is_terminal(self.stream) if bar is None else bar):
            from tqdm import tqdm

            self._bar = tqdm(total=total, desc=name, unit="step", file=self.stream, leave=False,
                             bar_format="{desc}: {n_fmt}/{total_fmt} |{bar}| {elapsed}<{remaining} {postfix}")

    def step(self, label: str) -> None:
        """Start the step ``label`` (the previous one is done)."""
        if self._bar is not None:
            if self.done:
                self._bar.update(1)
            self._bar.set_postfix_str(label)
        elif not self.quiet:
            print(f"[{self.name}] {label} ({self.done + 1}/{self.total}) …", file=self.stream, flush=True)
        self.done += 1

    def write(self, line: str) -> None:
        """A line on stderr that does not break the bar."""
        if self._bar is not None:
            self._bar.write(line, file=self.stream)
        elif not self.quiet:
            print(line, file=self.stream, flush=True)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.update(self.total - self._bar.n)
            self._bar.close()
            self._bar = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


def debugging() -> bool:
    """True under ``tendyn --debug`` (the entry point sets ``TENDYN_DEBUG=1``)."""
    import os

    return os.environ.get("TENDYN_DEBUG", "") not in ("", "0")


def quiet_dask() -> None:
    """Hide Dask's worker, nanny and scheduler warnings (unless ``--debug``): the ``distributed`` loggers of this
    process at ERROR, and the same level for the worker processes a local cluster spawns after this call (through
    Dask's configuration, which they read at start)."""
    if debugging():
        return
    import logging
    import os

    os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", "error")
    for name in ("distributed", "distributed.nanny", "distributed.worker", "distributed.scheduler",
                 "distributed.core", "distributed.utils_perf", "distributed.shuffle"):
        logging.getLogger(name).setLevel(logging.ERROR)
    try:
        import dask

        dask.config.set({"logging.distributed": "error"})
    except ImportError:
        pass


class Ticker:
    """``progress(message)`` callback of a long run whose number of steps is not known in advance (the pipelines'
    ``progress=``): on a terminal one tqdm line with the current step, the steps done, elapsed time and (with
    ``expected``, the usual number of steps) an ETA; elsewhere ``[name] message …`` lines."""

    def __init__(self, name: str, expected: int | None = None, *, stream: TextIO | None = None):
        self.name, self.expected = name, expected
        self.stream = sys.stderr if stream is None else stream
        self._bar = None
        self.count = 0

    def __call__(self, message: str) -> None:
        if message.startswith(f"{self.name}: "):           # callers that name themselves ("maps: …")
            message = message[len(self.name) + 2:]
        if not is_terminal(self.stream):
            print(f"[{self.name}] {message} …", file=self.stream, flush=True)
            return
        if self._bar is None:
            from tqdm import tqdm

            self._bar = tqdm(total=self.expected, desc=self.name, unit="step", file=self.stream, leave=False)
        elif self.count:
            self._bar.update(1)
        if self.expected is not None and self.count >= self._bar.total:
            self._bar.total = self.count + 1
        self._bar.set_postfix_str(message[:60])
        self.count += 1

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None
