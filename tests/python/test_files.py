"""Files as a user expects: modes, leftovers of killed runs, log/truth pairs (run id), all-or-none writes,
checking an output path before the work.

Killed runs are real: a child process is stopped inside a write (at a hook that prints ``ready`` and sleeps),
then killed with SIGKILL, so no ``except``/``finally`` of ours runs in it.
"""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from tendyn.io import files as files_mod
from tendyn.io import log_runs as runs_mod
from tendyn.io import logs as logs_mod
from tendyn.io.files import all_or_none, atomic_write_bytes, atomic_write_text, save_png
from tendyn.io.logs import (
    LogError,
    check_log_path,
    make_log,
    read_log,
    read_run,
    read_truth,
    truth_path,
    write_log,
    write_run,
    write_truth,
)

posix_only = pytest.mark.skipif(os.name != "posix", reason="signals and umask are POSIX")


def small_log(n=5, seed=None) -> "logs_mod.Log":
    t = np.arange(n) * 1e-3
    return make_log({"time": t, "q_motor_1": np.sin(t), "torque_motor_1": np.cos(t)}, device="lexos",
                    rate_hz=1000.0, seed=seed, experiment="static")


def snapshot(folder: Path) -> dict:
    """Every entry under ``folder``: relative path → (mode, bytes or None for a folder)."""
    out = {}
    for p in sorted(folder.rglob("*")):
        out[str(p.relative_to(folder))] = (stat.S_IMODE(p.lstat().st_mode), None if p.is_dir() else p.read_bytes())
    return out


def dead_pid() -> int:
    """The pid of a process that has exited (and been reaped)."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


class Child:
    """A Python child process that runs ``code`` (in which ``HOLD()`` prints 'ready' and sleeps forever)."""

    PRELUDE = textwrap.dedent("""
        import sys, time
        def HOLD(*args, **kwargs):
            print("ready", flush=True)
            time.sleep(600)
    """)

    def __init__(self, code: str):
        self.proc = subprocess.Popen([sys.executable, "-c", self.PRELUDE + textwrap.dedent(code)],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)

    @property
    def pid(self) -> int:
        return self.proc.pid

    def wait_ready(self):
        line = self.proc.stdout.readline()
        if line.strip() != "ready":
            self.proc.kill()
            raise AssertionError(f"child did not reach its hold point: {line!r} {self.proc.stderr.read()}")
        return self

    def kill(self):
        self.proc.send_signal(signal.SIGKILL)
        self.proc.wait()
        self.proc.stdout.close()
        self.proc.stderr.close()


@pytest.fixture
def umask():
    """Set the process umask for one test and restore it."""
    old = os.umask(0o022)
    os.umask(old)
    yield lambda value: os.umask(value)
    os.umask(old)


# ----------------------------------------------------------------------------------------------------------
# Modes
# ----------------------------------------------------------------------------------------------------------

def _write_png(path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0, 1])
    save_png(fig, path)
    return [path]


def _write_in_stage(path):
    with all_or_none(path.parent) as stage:
        atomic_write_text(stage / path.name, "x")
        (stage / "sub").mkdir()
        atomic_write_text(stage / "sub" / "b.txt", "y")
    return [path, path.parent / "sub" / "b.txt"]


WRITERS = {
    "bytes": lambda p: [atomic_write_bytes(p, b"x")],
    "text": lambda p: [atomic_write_text(p, "x")],
    "png": _write_png,
    "log": lambda p: [write_log(small_log(), p.with_suffix(".csv"))],
    "truth": lambda p: [write_truth({"k": 1.0}, p.with_suffix(".csv"))],
    "run": lambda p: list(write_run(small_log(), {"k": 1.0}, p.with_suffix(".parquet"))),
    "all_or_none": _write_in_stage,
}


@posix_only
@pytest.mark.parametrize("mask, mode", [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
@pytest.mark.parametrize("writer", list(WRITERS))
def test_file_mode_follows_umask(tmp_path, umask, mask, mode, writer):
    umask(mask)
    for p in WRITERS[writer](tmp_path / "out" / "f.png"):
        assert stat.S_IMODE(p.stat().st_mode) == mode, (p, oct(p.stat().st_mode))
    umask(0o022)
    if writer == "all_or_none":  # the folders it makes get the normal mode too (not the staging folder's 0700)
        assert stat.S_IMODE((tmp_path / "out" / "sub").stat().st_mode) == 0o777 & ~mask


@posix_only
def test_replacing_a_file_gives_the_normal_mode(tmp_path, umask):
    umask(0o022)
    p = tmp_path / "f.json"
    p.write_text("old")
    p.chmod(0o600)
    atomic_write_text(p, "new")
    assert stat.S_IMODE(p.stat().st_mode) == 0o644 and p.read_text() == "new"


# ----------------------------------------------------------------------------------------------------------
# Temporary files of killed runs
# ----------------------------------------------------------------------------------------------------------

def temps(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


@posix_only
def test_killed_write_leaves_no_temp_after_the_next_write(tmp_path):
    target = tmp_path / "result.json"
    atomic_write_text(target, "old")
    child = Child(f"""
        import os
        import tendyn.io.files as f
        os.replace = HOLD                       # stop after the temporary file is written, before the rename
        f.atomic_write_bytes({str(target)!r}, b"new" * 1000)
    """).wait_ready()
    left = temps(tmp_path)
    assert left and all(f".{child.pid}." in name for name in left), left
    child.kill()
    assert temps(tmp_path) == left and target.read_text() == "old"  # the kill left it; the old file is intact

    atomic_write_text(target, "next")
    assert temps(tmp_path) == [] and target.read_text() == "next"


@posix_only
def test_only_stale_temps_of_the_same_target_are_removed(tmp_path):
    target = tmp_path / "run.csv"
    live = Child("HOLD()").wait_ready()
    try:
        rnd = "0123456789abcdef"
        names = {
            "dead": f".run.csv.{dead_pid()}.{rnd}.tmp",
            "live": f".run.csv.{live.pid}.{rnd}.tmp",
            "old_live": f".run.csv.{live.pid}.{rnd[::-1]}.tmp",
            "own_pid": f".run.csv.{os.getpid()}.{rnd}.tmp",   # an earlier process that had our pid
            "other_target": f".other.csv.{dead_pid()}.{rnd}.tmp",
            "not_ours": ".run.csv.notes.tmp",
            "prefix_target": f".run.csv.x.{dead_pid()}.{rnd}.tmp",
        }
        for name in names.values():
            (tmp_path / name).write_bytes(b"partial")
        hour_ago = time.time() - files_mod.TEMP_MAX_AGE_S - 60
        os.utime(tmp_path / names["old_live"], (hour_ago, hour_ago))

        atomic_write_bytes(target, b"x")
        kept = {k for k, name in names.items() if (tmp_path / name).exists()}
        assert kept == {"live", "other_target", "not_ours", "prefix_target"}
    finally:
        live.kill()
    atomic_write_bytes(target, b"y")  # the writer is gone now: its temporary file is stale
    assert not (tmp_path / names["live"]).exists()


# ----------------------------------------------------------------------------------------------------------
# A log and its truth: one run id
# ----------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_write_run_pairs_log_and_truth(tmp_path, suffix):
    log, truth = small_log(), {"stiffness_motor": np.array([1.5e3]), "k": 1}
    meta_before = dict(log.meta)
    lp, tp = write_run(log, truth, tmp_path / f"run{suffix}")
    assert (lp, tp) == (tmp_path / f"run{suffix}", truth_path(lp))
    assert log.meta == meta_before and "run_id" not in truth  # the inputs are not changed
    back, back_truth = read_run(lp)
    run_id = back.meta["run_id"]
    assert len(run_id) == 32 and int(run_id, 16) >= 0
    assert back_truth["run_id"] == run_id and back_truth["stiffness_motor"] == [1.5e3]
    assert read_truth(lp) == back_truth
    # a second run draws a new id
    write_run(log, truth, lp)
    assert read_run(lp)[0].meta["run_id"] != run_id


def test_write_run_writes_the_truth_first(tmp_path, monkeypatch):
    order = []
    real = runs_mod.atomic_write_bytes
    monkeypatch.setattr(runs_mod, "atomic_write_bytes", lambda p, d: order.append(Path(p).name) or real(p, d))
    write_run(small_log(), {"k": 1}, tmp_path / "run.csv")
    assert order == ["run.truth.json", "run.csv"]


@posix_only
@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_interrupted_run_is_detected(tmp_path, suffix):
    """Two runs to one path, the second killed between its truth and its log: the reader says so."""
    path = tmp_path / f"run{suffix}"
    write_run(small_log(5, seed=1), {"k": 1.0}, path)
    old_log = read_log(path)
    child = Child(f"""
        import numpy as np
        import tendyn.io.log_runs as R
        import tendyn.io.logs as L
        real, calls = R.atomic_write_bytes, []
        def hold_second(p, data):
            calls.append(p)
            if len(calls) == 2:
                HOLD()
            return real(p, data)
        R.atomic_write_bytes = hold_second
        t = np.arange(9) * 1e-3
        log = L.make_log({{"time": t, "q_motor_1": t}}, device="lexos", rate_hz=1000.0, seed=2, experiment="static")
        L.write_run(log, {{"k": 2.0}}, {str(path)!r})
    """).wait_ready()
    child.kill()

    assert read_log(path) == old_log                     # the old log is intact (the truth went first) …
    for read in (read_run, read_truth):                 # … but its truth is the new run's
        with pytest.raises(LogError) as err:
            read(path)
        msg = str(err.value)
        assert f"run.truth.json: belongs to another run than the log run{suffix}" in msg, msg
        assert old_log.meta["run_id"][:8] in msg and "interrupted" in msg and "\n" not in msg
    write_run(small_log(7), {"k": 3.0}, path)            # a complete run repairs the pair
    log, truth = read_run(path)
    assert log.n_samples == 7 and truth["k"] == 3.0


@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_failed_log_write_after_truth_is_detected(tmp_path, monkeypatch, suffix):
    path = tmp_path / f"run{suffix}"
    write_run(small_log(5), {"k": 1.0}, path)
    real = runs_mod.atomic_write_bytes

    def disk_full_on_log(p, data):
        if Path(p) == path:
            raise OSError(28, "No space left on device (simulated)")
        return real(p, data)

    monkeypatch.setattr(runs_mod, "atomic_write_bytes", disk_full_on_log)
    with pytest.raises(OSError, match="simulated"):
        write_run(small_log(9), {"k": 2.0}, path)
    monkeypatch.undo()
    with pytest.raises(LogError, match="belongs to another run"):
        read_run(path)


def test_invalid_log_writes_nothing(tmp_path):
    path = tmp_path / "run.csv"
    write_run(small_log(5), {"k": 1.0}, path)
    before = snapshot(tmp_path)
    bad = small_log(5)
    bad.columns["q_motor_1"][2] = np.nan
    with pytest.raises(LogError, match="not finite"):
        write_run(bad, {"k": 2.0}, path)
    with pytest.raises(LogError, match="not JSON-serialisable"):
        write_run(small_log(5), {"k": float("nan")}, path)
    assert snapshot(tmp_path) == before
    read_run(path)


def test_log_replaced_alone_no_longer_pairs(tmp_path):
    path = tmp_path / "run.csv"
    write_run(small_log(5), {"k": 1.0}, path)
    write_log(small_log(6), path)          # a log without run id over a pair
    with pytest.raises(LogError, match=r"run id [0-9a-f]{8}… in the truth vs none in the log"):
        read_run(path)
    write_truth({"k": 2.0}, path)          # now neither has an id: an old-style pair
    log, truth = read_run(path)
    assert "run_id" not in log.meta and truth == {"k": 2.0}


def test_truth_without_id_beside_log_with_id(tmp_path):
    path = tmp_path / "run.parquet"
    write_run(small_log(5), {"k": 1.0}, path)
    write_truth({"k": 2.0}, path)
    with pytest.raises(LogError, match=r"run id none in the truth vs [0-9a-f]{8}… in the log"):
        read_truth(path)


def test_copying_a_pair_keeps_it_a_pair(tmp_path):
    a, b = tmp_path / "a.csv", tmp_path / "b" / "b.parquet"
    write_run(small_log(5), {"k": 1.0}, a)
    write_log(read_log(a), b)
    write_truth(read_truth(a), b)
    assert read_run(b)[1]["run_id"] == read_log(a).meta["run_id"]


def test_read_truth_finds_the_run_id_of_a_hand_written_csv(tmp_path):
    """read_truth reads only the meta line of a CSV log: after a BOM and other comment lines."""
    path = tmp_path / "run.csv"
    write_run(small_log(3), {"k": 1.0}, path)
    run_id = read_log(path).meta["run_id"]
    text = path.read_text(encoding="utf-8")
    path.write_bytes(("\ufeff# written by hand\n" + text).encode("utf-8"))
    assert read_truth(path)["run_id"] == run_id
    path.write_bytes(("\ufeff# written by hand\n" + text.replace(run_id, "0" * 32)).encode("utf-8"))
    with pytest.raises(LogError, match="vs 00000000… in the log"):
        read_truth(path)


def test_truth_without_its_log_reads(tmp_path):
    path = tmp_path / "run.csv"
    write_truth({"k": 1.0, "run_id": "f" * 32}, path)
    assert read_truth(path)["k"] == 1.0


def test_run_id_in_meta_is_checked(tmp_path):
    log = small_log()
    log.meta["run_id"] = 5
    with pytest.raises(LogError, match="meta.run_id: got 5"):
        write_log(log, tmp_path / "run.csv")
    log.meta["run_id"] = "abc"
    write_log(log, tmp_path / "run.csv")
    assert read_log(tmp_path / "run.csv").meta["run_id"] == "abc"


# ----------------------------------------------------------------------------------------------------------
# All or none
# ----------------------------------------------------------------------------------------------------------

def test_all_or_none_moves_every_file(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("unrelated")
    (out / "a.json").write_text("old")
    with all_or_none(out) as stage:
        assert stage.parent == out and stage.name.startswith(".")
        atomic_write_text(stage / "a.json", "new")
        write_run(small_log(), {"k": 1.0}, stage / "logs" / "run.csv")
        assert not (out / "logs").exists()           # nothing visible before the end
    assert sorted(snapshot(out)) == ["a.json", "keep.txt", "logs", "logs/run.csv", "logs/run.truth.json"]
    assert (out / "a.json").read_text() == "new" and (out / "keep.txt").read_text() == "unrelated"
    read_run(out / "logs" / "run.csv")


def test_all_or_none_on_error_leaves_the_folder_as_it_was(tmp_path):
    out = tmp_path / "out"
    atomic_write_text(out / "a.json", "old")
    atomic_write_text(out / "logs" / "b.json", "old b")
    before = snapshot(out)
    with pytest.raises(RuntimeError, match="simulated"):
        with all_or_none(out) as stage:
            atomic_write_text(stage / "a.json", "new")
            atomic_write_text(stage / "logs" / "b.json", "new b")
            atomic_write_text(stage / "c.json", "new c")
            raise RuntimeError("simulated failure after some files")
    assert snapshot(out) == before


def test_all_or_none_on_error_removes_the_folders_it_made(tmp_path):
    with pytest.raises(KeyboardInterrupt):
        with all_or_none(tmp_path / "a" / "b" / "out") as stage:
            atomic_write_text(stage / "x.json", "new")
            raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


def test_all_or_none_checks_every_target_before_moving(tmp_path):
    out = tmp_path / "out"
    atomic_write_text(out / "a.json", "old")
    (out / "z.png").mkdir()                          # a folder where a file must go, sorted after a.json
    before = snapshot(out)
    with pytest.raises(IsADirectoryError, match="z.png: is a folder"):
        with all_or_none(out) as stage:
            atomic_write_text(stage / "a.json", "new")
            atomic_write_text(stage / "z.png", "new")
    assert snapshot(out) == before


def test_all_or_none_refuses_a_file_as_folder(tmp_path):
    (tmp_path / "out").write_text("a file")
    with pytest.raises(NotADirectoryError, match="is a file"):
        with all_or_none(tmp_path / "out"):
            pass


@posix_only
def test_staging_of_a_killed_run_is_removed_on_next_use(tmp_path):
    out = tmp_path / "out"
    atomic_write_text(out / "a.json", "old")
    live = Child(f"""
        from tendyn.io.files import all_or_none
        with all_or_none({str(out)!r}) as stage:
            HOLD()
    """).wait_ready()
    killed = Child(f"""
        from tendyn.io.files import all_or_none, atomic_write_text
        with all_or_none({str(out)!r}) as stage:
            atomic_write_text(stage / "a.json", "from the killed run")
            HOLD()
    """).wait_ready()
    killed.kill()
    try:
        def staging_pids():
            return sorted(int(p.name.split(".")[2]) for p in out.iterdir() if p.name.startswith("."))

        assert staging_pids() == sorted([killed.pid, live.pid])
        with all_or_none(out) as stage:
            atomic_write_text(stage / "b.json", "b")
        assert staging_pids() == [live.pid]           # the killed run's staging is gone, the live one's kept
    finally:
        live.kill()
    assert (out / "a.json").read_text() == "old" and (out / "b.json").read_text() == "b"


# ----------------------------------------------------------------------------------------------------------
# Checking an output path before the work
# ----------------------------------------------------------------------------------------------------------

def test_check_log_path_accepts(tmp_path):
    for name in ("run.csv", "run.parquet", "RUN.CSV", "deep/er/run.Parquet"):
        assert check_log_path(tmp_path / name) == tmp_path / name
    assert list(tmp_path.iterdir()) == []               # creates nothing
    (tmp_path / "old.csv").write_text("x")
    check_log_path(tmp_path / "old.csv")                # an existing file is replaced by the write


@pytest.mark.parametrize("name, setup, fragment", [
    ("run.txt", None, "unknown log format '.txt'"),
    ("run", None, "unknown log format '(no suffix)'"),
    ("run.csv", "folder", "is a folder"),
    ("f/run.csv", "file", "f is a file, not a folder"),
    ("f/sub/run.csv", "file", "f is a file, not a folder"),
])
def test_check_log_path_refuses(tmp_path, name, setup, fragment):
    path = tmp_path / name
    if setup == "folder":
        path.mkdir()
    elif setup == "file":
        (tmp_path / "f").write_text("x")
    before = snapshot(tmp_path)
    with pytest.raises(LogError) as err:
        check_log_path(path)
    assert fragment in str(err.value) and str(path) in str(err.value) and "\n" not in str(err.value)
    assert snapshot(tmp_path) == before


def test_check_log_path_unwritable(tmp_path, monkeypatch):
    (tmp_path / "ro").mkdir()
    if os.name == "posix" and os.geteuid() != 0:
        (tmp_path / "ro").chmod(0o555)
    else:  # root may write anywhere: pretend the folder is read-only
        real = os.access
        monkeypatch.setattr(os, "access", lambda p, mode: False if Path(p).name == "ro" else real(p, mode))
    try:
        with pytest.raises(LogError, match="no permission to write in the folder .*ro"):
            check_log_path(tmp_path / "ro" / "new" / "run.csv")
    finally:
        (tmp_path / "ro").chmod(0o755)


def test_write_log_uses_the_check(tmp_path):
    (tmp_path / "run.csv").mkdir()
    with pytest.raises(LogError, match="is a folder"):
        write_log(small_log(), tmp_path / "run.csv")
