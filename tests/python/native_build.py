"""Build the native examples (examples/) against an installed tendyn package, the three ways docs/c-package.md
shows a user: CMake (find_package(tendyn)), pkg-config and `tendyn config --cflags --libs`. Used by
test_examples.py and test_package.py."""

from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = REPO / "examples"
TENDYN = Path(sys.executable).with_name("tendyn")  # the console script of the installed package
# program name → (source, language); the same names as examples/CMakeLists.txt
PROGRAMS = {
    "feedforward_c": ("01_feedforward/feedforward.c", "c"),
    "feedforward_cpp": ("01_feedforward/feedforward.cpp", "cpp"),
    "compensation_c": ("02_compensation/compensation.c", "c"),
    "compensation_cpp": ("02_compensation/compensation.cpp", "cpp"),
}
ROUTES = ("cmake", "pkg-config", "tendyn-config")


def installed_package():
    """The installed C/C++ package (tendyn.c_package.CPackage); skip (or fail under `make test`) without it."""
    from tendyn import c_package

    pkg = c_package.find()
    if not pkg.installed() or not TENDYN.exists():
        if os.environ.get("TENDYN_REQUIRE_EXAMPLES"):
            pytest.fail(f"the C/C++ package is not installed in {pkg.prefix} (make install)")
        pytest.skip(f"the C/C++ package is not installed in {pkg.prefix} (run `make install`)")
    return pkg


def run(cmd, **kw) -> str:
    """Run a command; its output in the failure message."""
    r = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if r.returncode:
        pytest.fail(f"{' '.join(map(str, cmd))} exited {r.returncode}:\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}")
    return r.stdout


def tendyn_config(*options: str) -> str:
    return run([str(TENDYN), "config", *options]).strip()


def user_env() -> dict:
    """The environment of a user's shell: no LD_LIBRARY_PATH, so the programs find libtendyn_c by their rpath."""
    env = dict(os.environ)
    env.pop("LD_LIBRARY_PATH", None)
    return env


def build(route: str, out: Path, cmake_prefix_path: str | None = None, pkg_config_path: str | None = None,
          only: tuple[str, ...] | None = None, cmake_build_type: str | None = None) -> dict:
    """Build the four programs (or ``only`` those named) into ``out`` by ``route``; returns name → executable
    path. The paths default to what `tendyn config` prints (another install tree can be given, e.g. a
    `cmake --install` prefix). ``cmake_build_type``: CMAKE_BUILD_TYPE of the cmake route (default: the examples'
    own, Release; ``"None"``: no optimisation flags, where only the paths are checked)."""
    out.mkdir(parents=True, exist_ok=True)
    names = tuple(PROGRAMS) if only is None else only
    if route == "cmake":
        prefix = cmake_prefix_path or tendyn_config("--cmake-prefix-path")
        build_type = [] if cmake_build_type is None else [f"-DCMAKE_BUILD_TYPE={cmake_build_type}"]
        run(["cmake", "-S", str(EXAMPLES), "-B", str(out), f"-DCMAKE_PREFIX_PATH={prefix}", *build_type],
            env=user_env())
        run(["cmake", "--build", str(out), "-j", "2", *([] if only is None else ["--target", *only])])
        return {name: out / name for name in names}
    if route == "pkg-config":
        if shutil.which("pkg-config") is None:
            pytest.fail("pkg-config is not installed (`make test` installs it with apt)")
        env = dict(user_env(), PKG_CONFIG_PATH=pkg_config_path or tendyn_config("--pkg-config-path"))
        c_flags = run(["pkg-config", "--cflags", "--libs", "tendyn"], env=env).split()
        cpp_flags = run(["pkg-config", "--cflags", "tendyn-cpp"], env=env).split()
    elif route == "tendyn-config":
        c_flags = shlex.split(tendyn_config("--cflags", "--libs"))
        cpp_flags = shlex.split(tendyn_config("--cflags", "--cpp"))
    else:
        raise ValueError(route)
    exes = {}
    for name in names:
        source, lang = PROGRAMS[name]
        # feedforward.cpp is the header-only core (Eigen); compensation.cpp calls the C ABI from C++
        flags = cpp_flags if name == "feedforward_cpp" else c_flags
        # the commands of docs/c-package.md as written (no -O: the optimiser changes no number here, no
        # -ffast-math, and -O2 made feedforward.cpp, the core's fixed-size paths for 1–6 transmissions, 11 s of
        # compiler CPU against 6 s: issue 39)
        compiler = ["cc"] if lang == "c" else ["c++", "-std=c++17"]
        exes[name] = out / name
        run([*compiler, str(EXAMPLES / source), "-o", str(exes[name]), *flags, "-lm"])
    return exes
