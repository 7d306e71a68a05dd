"""Files as a user expects: atomic writes with the normal mode, all-or-none sets of files, no stale leftovers.

* :func:`atomic_write_bytes` / :func:`atomic_write_text` write through a temporary file in the target's folder
  and rename it over the target, so a reader sees the old file or the new one, never half of one. The file gets
  the mode a plain ``open(path, "w")`` gives: ``0o666 & ~umask`` (0644 under umask 022).
* :func:`all_or_none` stages several files in a hidden folder and moves them into place only when the code that
  writes them has finished without an exception.
* A run killed while writing (SIGKILL, out of memory, power loss) leaves a temporary file or a staging folder.
  Their names carry the writer's process id, ``.{name}.{pid}.{random}.tmp`` and
  ``.tendyn-staging.{pid}.{random}``, so the next write to the same place recognises and removes the stale ones
  (:func:`remove_stale`) and never those of a writer that is still running.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import secrets
import shutil
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np

__all__ = [
    "creatable",
    "interrupts_deferred",
    "STAGING_MAX_AGE_S",
    "TEMP_MAX_AGE_S",
    "all_or_none",
    "atomic_write_bytes",
    "atomic_write_text",
    "atomic_write_rows",
    "remove_stale",
    "save_png",
    "to_jsonable",
]

TEMP_MAX_AGE_S = 3600.0
"""Age [s] after which a temporary file is stale even if a process with its pid runs (a recycled pid, or a
writer on another machine sharing the folder). An atomic write lasts well under a second."""

STAGING_MAX_AGE_S = 24 * 3600.0
"""Age [s] after which a staging folder of :func:`all_or_none` is stale even if a process with its pid runs."""

_STAGING_PREFIX = ".tendyn-staging"
_STAGING_RE = re.compile(re.escape(_STAGING_PREFIX) + r"\.([1-9][0-9]*)\.[0-9a-f]{16}")

# Temporary files and staging folders this process is writing right now. A leftover that carries our pid but
# is not in this set was left by an earlier process that had the same pid (in a container every run may be pid 1).
_IN_FLIGHT: set[Path] = set()


# ----------------------------------------------------------------------------------------------------------
# Stale leftovers of killed runs
# ----------------------------------------------------------------------------------------------------------

def _temp_pattern(target: Path) -> re.Pattern:
    """Names of the temporary files of writes to ``target``; group 1 is the writer's pid."""
    return re.compile(r"\." + re.escape(target.name) + r"\.([1-9][0-9]*)\.[0-9a-f]{16}\.tmp")


def _pid_alive(pid: int) -> bool:
    """Whether a process with this pid runs on this machine (True when it cannot be told)."""
    if os.name == "nt":  # os.kill(pid, 0) would terminate the process on Windows
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # it runs, under another user
        return True
    except (OverflowError, ValueError):  # not a pid this system can have
        return False
    except OSError:
        return True
    return True


def _is_stale(entry: Path, pid: int, max_age_s: float) -> bool:
    """Whether ``entry``, named with the writer's ``pid``, is a leftover no running write owns."""
    if entry in _IN_FLIGHT:
        return False
    if pid == os.getpid():
        return True  # our pid but not our write: an earlier process that had the same pid
    if not _pid_alive(pid):
        return True
    try:
        return time.time() - entry.lstat().st_mtime > max_age_s
    except OSError:  # already gone
        return False


def remove_stale(folder, pattern: re.Pattern, max_age_s: float) -> list[Path]:
    """Remove the leftovers of killed writers in ``folder``: entries whose name fully matches ``pattern``
    (group 1: the writer's pid) and whose writer no longer runs, or that are older than ``max_age_s`` [s].

    Best effort: an entry that cannot be removed is left, and a missing folder is not an error.

    Returns
    -------
    list of pathlib.Path
        The entries removed.
    """
    folder = Path(folder)
    try:
        names = os.listdir(folder)
    except OSError:
        return []
    removed = []
    for name in names:
        m = pattern.fullmatch(name)
        if m is None:
            continue
        entry = folder / name
        if not _is_stale(entry, int(m.group(1)), max_age_s):
            continue
        try:
            if entry.is_dir() and not entry.is_symlink():
                shutil.rmtree(entry)
            else:
                entry.unlink()
        except OSError:
            continue
        removed.append(entry)
    return removed


def _create_unique(folder: Path, make_name, create):
    """Create ``folder / make_name(pid, random hex)`` with ``create``, which must raise ``FileExistsError`` if
    the name exists; retry on such a collision. Returns the path and what ``create`` returned."""
    while True:
        candidate = folder / make_name(os.getpid(), secrets.token_hex(8))
        try:
            return candidate, create(candidate)
        except FileExistsError:
            continue


# ----------------------------------------------------------------------------------------------------------
# Atomic writes
# ----------------------------------------------------------------------------------------------------------

def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically: a reader sees the old file or the new one, never part of one.

    The data goes to a temporary file in the same folder, is flushed to the disk, then renamed over ``path``.
    The folder is created if needed. The file gets mode ``0o666 & ~umask`` (0644 under umask 022), like a
    file created by ``open``. Stale temporary files of killed writes to the same ``path`` are removed first.

    Parameters
    ----------
    path : path-like
        The target file.
    data : bytes
        The whole content.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    OSError
        If the folder or the file cannot be written; ``path`` is then left as it was and no temporary file
        remains.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_stale(path.parent, _temp_pattern(path), TEMP_MAX_AGE_S)
    # mode 0o666: the kernel applies the umask, as for any file a program creates (mkstemp would give 0600)
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0)
    tmp, fd = _create_unique(path.parent, lambda pid, rnd: f".{path.name}.{pid}.{rnd}.tmp",
                             lambda p: os.open(p, flags, 0o666))
    _IN_FLIGHT.add(tmp)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())  # the data is on the disk before the name points to it
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    finally:
        _IN_FLIGHT.discard(tmp)
    return path


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """:func:`atomic_write_bytes` of ``text`` encoded as UTF-8."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_rows(path: str | os.PathLike, rows: list[dict]) -> Path:
    """:func:`atomic_write_bytes` of ``rows`` (dicts with the same keys) as one Parquet table, with page
    checksums (readers can verify it)."""
    import io

    import pyarrow as pa
    import pyarrow.parquet as pq

    buf = io.BytesIO()
    pq.write_table(pa.Table.from_pylist(rows), buf, write_page_checksum=True)
    return atomic_write_bytes(path, buf.getvalue())


def save_png(fig, path, dpi: int = 130) -> Path:
    """Render a matplotlib figure to PNG [``dpi`` dots per inch] and write it atomically; closes the figure."""
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    plt.close(fig)
    return atomic_write_bytes(path, buf.getvalue())


# ----------------------------------------------------------------------------------------------------------
# Several files: all or none
# ----------------------------------------------------------------------------------------------------------

def creatable(path) -> tuple[Path, str | None]:
    """Whether ``path`` (file or folder) could be created, before the work that produces it; creates nothing.

    Returns the nearest existing ancestor of ``path`` and ``None`` if it is a folder this user can write into,
    else ``"not a folder"`` or ``"permission denied"`` (callers word the error for their option).
    """
    parent = Path(path).parent
    while not parent.exists() and parent.parent != parent:
        parent = parent.parent
    if not parent.is_dir():
        return parent, "not a folder"
    if not os.access(parent, os.W_OK | os.X_OK):
        return parent, "permission denied"
    try:    # os.access says yes to root everywhere: /proc and read-only mounts refuse only an actual create
        with tempfile.TemporaryFile(dir=parent):   # unnamed (O_TMPFILE) where the system has it: nothing shows
            pass
    except OSError:
        return parent, "permission denied"
    return parent, None


def _make_folders(folder: Path) -> list[Path]:
    """Create ``folder`` and its missing parents; return those this call created, outermost first."""
    missing = []
    p = folder
    while not p.exists():
        missing.append(p)
        if p.parent == p:
            break
        p = p.parent
    if p.exists() and not p.is_dir():
        raise NotADirectoryError(f"{folder}: {p} is a file, not a folder")
    created = []
    for d in reversed(missing):
        try:
            d.mkdir()
        except FileExistsError:  # made meanwhile by someone else: not ours to remove
            continue
        created.append(d)
    return created


def _remove_folders(created: list[Path]) -> None:
    """Undo :func:`_make_folders` where the folders are still empty."""
    for d in reversed(created):
        with contextlib.suppress(OSError):
            d.rmdir()


def _plan_moves(stage: Path, folder: Path) -> tuple[list[Path], list[tuple[Path, Path]]]:
    """Folders to create and ``(source, target)`` file moves that put the content of ``stage`` into
    ``folder``; raises before anything is moved if a target cannot take its file."""
    dirs, moves = [], []

    def walk(src_dir: Path, dst_dir: Path) -> None:
        for entry in sorted(os.scandir(src_dir), key=lambda e: e.name):
            dst = dst_dir / entry.name
            if entry.is_dir(follow_symlinks=False):
                if dst.exists() and not dst.is_dir():
                    raise NotADirectoryError(f"{dst}: is a file, the new output needs a folder there")
                dirs.append(dst)
                walk(Path(entry.path), dst)
            else:
                if dst.is_dir() and not dst.is_symlink():
                    raise IsADirectoryError(f"{dst}: is a folder, the new output needs a file there")
                moves.append((Path(entry.path), dst))

    walk(stage, folder)
    return dirs, moves


@contextlib.contextmanager
def interrupts_deferred() -> Iterator[None]:
    """Hold Ctrl-C (SIGINT) while a set of files is being put in place: the block finishes, then the interrupt
    is raised (KeyboardInterrupt: exit 130 with the whole set written). Outside the main thread, or if SIGINT
    is ignored (a background job), the block just runs."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.getsignal(signal.SIGINT)
    if old is signal.SIG_IGN or old is None:
        yield
        return
    held: list[int] = []
    signal.signal(signal.SIGINT, lambda signum, frame: held.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)
    if held:
        raise KeyboardInterrupt


@contextlib.contextmanager
def all_or_none(folder) -> Iterator[Path]:
    """Write several files into ``folder`` as one: all of them, or (on an exception) none.

    Yields a staging folder (hidden, ``folder/.tendyn-staging.<pid>.<random>``, so on the same file system);
    the code in the ``with`` block writes its files (and subfolders) there. On normal exit every file is moved
    to the same relative place in ``folder``, each by ``os.replace`` (an old file of the same name is replaced;
    other files in ``folder`` are kept). On an exception the staging folder is removed and ``folder`` is left
    exactly as it was (if this call created it, or its parents, they are removed again). Staging folders of
    killed runs are removed on the next use of the same ``folder``.

    >>> with all_or_none("results") as stage:               # doctest: +SKIP
    ...     atomic_write_text(stage / "summary.json", text)
    ...     save_png(fig, stage / "figure.png")

    Notes
    -----
    Before the first move every target is checked (a folder where a file must go, or the reverse, raises
    before anything is moved). The moves themselves are separate renames, one per file, done in sorted
    order within microseconds: a process killed (or a power loss) in that window leaves some new and some
    old files. This window is not closed (that would need a journal replayed by readers); a log and its truth
    file carry one run id, so a reader detects such a mixed pair (``tendyn.io.logs.read_run``). An ``OSError``
    during the moves (rare, after the checks) propagates with the files moved so far in place.

    Parameters
    ----------
    folder : path-like
        The output folder; created if needed.

    Yields
    ------
    pathlib.Path
        The staging folder to write into.
    """
    folder = Path(folder)
    created = _make_folders(folder)
    try:
        remove_stale(folder, _STAGING_RE, STAGING_MAX_AGE_S)
        stage, _ = _create_unique(folder, lambda pid, rnd: f"{_STAGING_PREFIX}.{pid}.{rnd}",
                                  lambda p: p.mkdir(mode=0o700))
    except BaseException:
        _remove_folders(created)
        raise
    _IN_FLIGHT.add(stage)
    try:
        try:
            yield stage
            dirs, moves = _plan_moves(stage, folder)
        except BaseException:
            shutil.rmtree(stage, ignore_errors=True)
            _remove_folders(created)
            raise
        with interrupts_deferred():              # a Ctrl-C here would leave some new and some old files
            for d in dirs:
                d.mkdir(exist_ok=True)
            for src, dst in moves:
                os.replace(src, dst)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
        _IN_FLIGHT.discard(stage)


# ----------------------------------------------------------------------------------------------------------
# JSON
# ----------------------------------------------------------------------------------------------------------

MAX_JSON_BYTES = 64 * 2**20
"""Largest JSON document a user may give [bytes] (64 MiB). tendyn's own (PARAMS.json, FRICTION.json, a log's
meta, shares) are kilobytes; a bigger one is a mistake (a log given for a parameters file) that would otherwise
be read whole into memory and parsed for minutes."""


def parse_json(text: str, **kw):
    """``json.loads`` for a document a user gives: one nested deeper than the interpreter's recursion limit
    (~1000 levels; `[[[[…` 100 000 deep), larger than :data:`MAX_JSON_BYTES` or holding an integer longer than
    the interpreter converts (4300 digits) raises :class:`json.JSONDecodeError` like any bad JSON, never a
    RecursionError or a bare ValueError, so every reader reports it as a bad file."""
    if len(text) > MAX_JSON_BYTES:
        raise json.JSONDecodeError(f"larger than {MAX_JSON_BYTES // 2**20} MiB", "", 0)
    try:
        return json.loads(text, **kw)
    except RecursionError:
        raise json.JSONDecodeError(f"nested deeper than {sys.getrecursionlimit()} levels", "", 0) from None
    except json.JSONDecodeError:
        raise
    except ValueError as exc:            # an integer of more than sys.get_int_max_str_digits() digits
        raise json.JSONDecodeError(" ".join(str(exc).split()), "", 0) from None


def read_json(path, **kw):
    """Read and parse a JSON file: raises OSError, or :class:`json.JSONDecodeError` for a file that is larger than
    :data:`MAX_JSON_BYTES` (checked before reading), not UTF-8 text, not JSON or nested too deep
    (:func:`parse_json`)."""
    path = Path(path)
    if path.stat().st_size > MAX_JSON_BYTES:
        raise json.JSONDecodeError(f"larger than {MAX_JSON_BYTES // 2**20} MiB", "", 0)
    data = path.read_bytes()
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise json.JSONDecodeError(f"not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start})", "",
                                   0) from None
    return parse_json(text, **kw)


def to_jsonable(value):
    """numpy arrays and scalars → lists and floats, paths → strings, recursively."""
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if isinstance(value, dict):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value
