#!/usr/bin/env python3
"""Mutation run: plant each bug of mutants.toml in a scratch copy, rebuild, run the tests, report the kill rate.

    python tests/mutants/run.py                      # the tests of the working tree (`make mutants`)
    python tests/mutants/run.py --tests-from main    # the tests of a git ref (e.g. the suite before a change)
    python tests/mutants/run.py --only bench-friction-other-tendon --full

The library under mutation is always the repository's working tree (include/, src/, bindings/, python/,
examples/, docs/, build files); only the tests/ folder comes from --tests-from. One scratch copy and one
incremental CMake build (the ``_core`` module, plus the CTest executables a mutant names) are reused: each
mutant is applied, built, tested and reverted before the next. The interpreter is this repository's
.venv (its site-packages provide numpy, pinocchio, ...); the scratch package is put first on PYTHONPATH.

KILLED = a CTest or pytest failure, SURVIVED = everything passed; a mutant that does not compile is
STILLBORN and left out of the rate (the list must hold plausible, compiling bugs). Before any mutant runs, every `find` text must occur exactly once (the list
must not rot silently) and the unmutated suite must pass in the scratch copy.
"""

from __future__ import annotations

import argparse
import io
import os
import re
import shutil
import signal
import subprocess
import sys
import tarfile
import time
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
LIST = Path(__file__).resolve().with_name("mutants.toml")
LIB_PATHS = ["include", "src", "bindings", "python", "examples", "docs", "benchmarks", "CMakeLists.txt", "pyproject.toml",
             "README.md", "Makefile"]
CPP_SUFFIXES = (".hpp", ".h", ".cpp", ".c", ".txt")


def sh(cmd, cwd=None, env=None, quiet=True, timeout=None) -> subprocess.CompletedProcess:
    return subprocess.run(cmd, cwd=cwd, env=env, text=True, capture_output=quiet, timeout=timeout)


def load_mutants(only: list[str] | None) -> list[dict]:
    data = tomllib.loads(LIST.read_text(encoding="utf-8"))
    muts = data["mutant"]
    ids = [m["id"] for m in muts]
    dup = {i for i in ids if ids.count(i) > 1}
    if dup:
        sys.exit(f"mutants.toml: duplicate id(s) {sorted(dup)}")
    bad = []
    for m in muts:
        for key in ("id", "file", "find", "replace", "breaks", "tests"):
            if key not in m:
                bad.append(f"{m.get('id', '?')}: missing {key}")
        text = (REPO / m["file"]).read_text(encoding="utf-8")
        n = text.count(m["find"])
        if n != 1:
            bad.append(f"{m['id']}: `find` occurs {n} times in {m['file']} (must be exactly once)")
    if bad:
        sys.exit("mutants.toml is out of date with the code:\n  " + "\n  ".join(bad))
    if only:
        unknown = set(only) - set(ids)
        if unknown:
            sys.exit(f"unknown mutant id(s): {sorted(unknown)}")
        muts = [m for m in muts if m["id"] in only]
    return muts


def _sync_file(src_bytes: bytes, dst: Path) -> None:
    """Write dst only if its content differs (a fresh mtime then makes the build see it)."""
    if dst.exists() and dst.read_bytes() == src_bytes:
        return
    dst.parent.mkdir(parents=True, exist_ok=True)
    dst.write_bytes(src_bytes)


def _tree_files(root: Path):
    for p in sorted(root.rglob("*")):
        if p.is_file() and "__pycache__" not in p.parts and p.suffix not in (".so", ".pyc"):
            yield p


def copy_library(scratch: Path) -> None:
    for rel in LIB_PATHS:
        src = REPO / rel
        if src.is_dir():
            for f in _tree_files(src):
                _sync_file(f.read_bytes(), scratch / f.relative_to(REPO))
        elif src.exists():
            _sync_file(src.read_bytes(), scratch / rel)


def copy_tests(scratch: Path, ref: str | None, dest: str = "tests") -> None:
    """The tests folder of the working tree (ref None) or of a git ref, as scratch/<dest>."""
    dst = scratch / dest
    if dst.exists():
        shutil.rmtree(dst)
    if ref is None:
        shutil.copytree(REPO / "tests", dst, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        return
    blob = subprocess.run(["git", "-C", str(REPO), "archive", "--format=tar", f"--prefix={dest}/", ref, "tests"],
                          check=True, capture_output=True).stdout
    staging = scratch / ".staging"
    if staging.exists():
        shutil.rmtree(staging)
    with tarfile.open(fileobj=io.BytesIO(blob)) as tar:
        tar.extractall(staging, filter="data")
    (staging / dest / "tests").rename(dst) if (staging / dest / "tests").exists() else (staging / dest).rename(dst)
    shutil.rmtree(staging, ignore_errors=True)


def ctest_targets(scratch: Path) -> dict[str, str]:
    """CTest name → executable target, from tests/cpp/CMakeLists.txt of the tests under test."""
    cm = scratch / "tests" / "cpp" / "CMakeLists.txt"
    if not cm.exists():
        return {}
    return dict(re.findall(r"add_test\(NAME\s+(\S+)\s+COMMAND\s+(\S+)", cm.read_text()))


class Scratch:
    def __init__(self, root: Path, python: Path, jobs: int):
        self.root, self.python, self.jobs = root, python, jobs
        self.build = root / "build" / "mut"
        self.configured = False

    def configure(self) -> None:
        self.build.mkdir(parents=True, exist_ok=True)
        r = sh(["cmake", "-S", str(self.root), "-B", str(self.build), "-DTENDYN_BUILD_PYTHON=ON",
                "-DTENDYN_BUILD_TESTS=ON", f"-DPython_EXECUTABLE={self.python}", "-DCMAKE_BUILD_TYPE=Release"])
        if r.returncode:
            sys.exit("cmake configure failed in the scratch copy:\n" + r.stdout[-3000:] + r.stderr[-3000:])
        # the scratch package loads Pinocchio's libraries through $ORIGIN/../cmeel.prefix/lib
        site = sh([str(self.python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"]).stdout.strip()
        link = self.root / "python" / "cmeel.prefix"
        if not link.exists():
            link.symlink_to(Path(site) / "cmeel.prefix")
        self.configured = True

    def make(self, targets: list[str]) -> tuple[bool, str]:
        r = sh(["cmake", "--build", str(self.build), "-j", str(self.jobs), "--target", *targets])
        if r.returncode:
            return False, (r.stdout + r.stderr)[-4000:]
        for so in self.build.glob("_core*.so"):
            shutil.copy2(so, self.root / "python" / "tendyn" / so.name)
        return True, ""

    def env(self) -> dict:
        env = dict(os.environ)
        env["PYTHONPATH"] = str(self.root / "python")
        env.pop("TENDYN_REQUIRE_EXAMPLES", None)
        return env

    def ctest(self, names: list[str]) -> tuple[bool, str]:
        if not names:
            return True, ""
        r = sh(["ctest", "--test-dir", str(self.build), "--output-on-failure", "-R",
                "^(" + "|".join(map(re.escape, names)) + ")$"], timeout=600)
        return r.returncode == 0, (r.stdout + r.stderr)[-3000:]

    def pytest(self, files: list[str], full: bool, tests_dir: str = "tests") -> tuple[bool, str]:
        # a mutant's listed files that the tests under test do not have (e.g. an older ref) are skipped;
        # with none left the whole suite runs
        files = [tests_dir + f[len("tests"):] for f in files]
        present = [f for f in files if (self.root / f).exists()]
        args = [f"{tests_dir}/python"] if full or not present else present
        r = sh([str(self.python), "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *args],
               cwd=self.root, env=self.env(), timeout=1800)
        tail = (r.stdout + r.stderr).strip().splitlines()
        failed = [ln for ln in tail if ln.startswith(("FAILED", "ERROR"))]
        return r.returncode == 0, (failed[0] if failed else (tail[-1] if tail else ""))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tests-from", default=None, help="git ref whose tests/ folder is run (default: working tree)")
    ap.add_argument("--before", default=None, metavar="REF",
                    help="also run REF's tests on every mutant (same build), e.g. the suite before a change: "
                         "prints both kill rates (REF's CTest is not run)")
    ap.add_argument("--scratch", default="/tmp/tendyn-mutants", help="scratch checkout (reused, incremental)")
    ap.add_argument("--only", nargs="*", help="mutant ids to run (default: all)")
    ap.add_argument("--full", action="store_true", help="run the whole pytest suite per mutant, not its listed files")
    ap.add_argument("--no-ctest", action="store_true", help="skip the CTest executables")
    ap.add_argument("--python-only", action="store_true",
                    help="run only the mutants of Python files, with the .venv's installed _core (no build: "
                         "quick, and can run beside a C++ run in another scratch)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--no-baseline", action="store_true", help="skip the check that the unmutated suite passes")
    args = ap.parse_args()
    signal.signal(signal.SIGTERM, lambda *_: sys.exit("terminated"))  # so that `finally` reverts the mutant

    muts = load_mutants(args.only)
    if args.python_only:
        muts = [m for m in muts if m["file"].endswith(".py")]
        args.no_ctest = True
    python = REPO / ".venv" / "bin" / "python"
    if not python.exists():
        sys.exit("no .venv: run `make install` first")
    scratch = Path(args.scratch)
    scratch.mkdir(parents=True, exist_ok=True)
    copy_library(scratch)
    copy_tests(scratch, args.tests_from)
    sets = [("after", "tests")]
    if args.before:
        copy_tests(scratch, args.before, "tests_before")
        sets.append(("before", "tests_before"))
    targets = {} if args.no_ctest else ctest_targets(scratch)
    s = Scratch(scratch, python, args.jobs)
    if args.python_only:
        installed = sh([str(python), "-c", "import tendyn._core as c; print(c.__file__)"]).stdout.strip()
        shutil.copy2(installed, scratch / "python" / "tendyn" / Path(installed).name)
        site = Path(installed).parents[1]
        link = scratch / "python" / "cmeel.prefix"
        if not link.exists():
            link.symlink_to(site / "cmeel.prefix")
        s.make = lambda targets: (True, "")  # type: ignore[method-assign]
    else:
        s.configure()
    label = args.tests_from or "working tree"
    print(f"mutants: {len(muts)} from {LIST.relative_to(REPO)}; tests from {label}"
          + (f", and from {args.before} (before)" if args.before else "") + f"; scratch {scratch}", flush=True)

    def wanted_ctests(m):
        return [n for n in m.get("ctest", []) if n in targets]

    all_ctests = sorted({n for m in muts for n in wanted_ctests(m)})
    t0 = time.time()
    ok, log = s.make(["_core", *[targets[n] for n in all_ctests]])
    if not ok:
        sys.exit("the unmutated scratch copy does not build:\n" + log)
    if not args.no_baseline:
        files = sorted({f for m in muts for f in m["tests"]})
        ok_c, out_c = s.ctest(all_ctests)
        if not ok_c:
            sys.exit(f"the unmutated CTest fails in the scratch copy:\n{out_c}")
        for name, folder in sets:
            ok_p, out_p = s.pytest(files, args.full, folder)
            if not ok_p:
                sys.exit(f"the unmutated suite ({name}) fails in the scratch copy, kill rates would be "
                         f"meaningless:\n{out_p}")
        print(f"baseline: unmutated suite passes ({time.time() - t0:.0f} s)", flush=True)

    results = []  # (mutant, {set: verdict}, {set: why})
    for m in muts:
        path = scratch / m["file"]
        original = path.read_text(encoding="utf-8")
        assert original.count(m["find"]) == 1, m["id"]
        t1 = time.time()
        verdict, why = {}, {}
        path.write_text(original.replace(m["find"], m["replace"], 1), encoding="utf-8")
        try:
            ctests = wanted_ctests(m)
            ok, log = s.make(["_core", *[targets[n] for n in ctests]])
            if not ok:
                for name, _ in sets:
                    verdict[name], why[name] = "STILLBORN", "does not compile: " + log.strip().splitlines()[-1]
            else:
                ok_c, out_c = s.ctest(ctests)
                for name, folder in sets:
                    if name == "after" and not ok_c:
                        verdict[name] = "KILLED"
                        why[name] = "ctest: " + " ".join(ln.strip() for ln in out_c.splitlines()
                                                         if "PHYSICS FAIL" in ln or "***Failed" in ln)[:200]
                        continue
                    ok_p, out_p = s.pytest(m["tests"], args.full, folder)
                    verdict[name], why[name] = ("SURVIVED", "") if ok_p else ("KILLED", out_p[:160])
        finally:
            path.write_text(original, encoding="utf-8")
        results.append((m, verdict, why))
        line = " ".join(f"{n}={verdict[n]:9s}" for n, _ in sets)
        print(f"{m['id']:36s} {line} {time.time() - t1:4.0f} s  {why['after'] or why.get('before', '')}", flush=True)

    print()
    for name, _ in sets:
        counted = [r for r in results if r[1][name] != "STILLBORN"]
        killed = sum(r[1][name] == "KILLED" for r in counted)
        ref = label if name == "after" else args.before
        print(f"kill rate ({name}, tests from {ref}): {killed}/{len(counted)} = "
              f"{100.0 * killed / max(1, len(counted)):.0f} %")
        for m, v, _ in results:
            if v[name] == "SURVIVED":
                print(f"  survived: {m['id']}: {m['breaks']}")
    print(f"({time.time() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
