"""The installed C/C++ package (docs/c-package.md): its files, `tendyn config`, the CMake package and the
pkg-config files, used from outside the repository as a user would (a relocated copy, a C-only consumer without
Eigen, a plain `cmake --install`)."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from native_build import TENDYN, build, installed_package, run, tendyn_config, user_env

REPO = Path(__file__).resolve().parents[2]
LEXOS_MODEL = REPO / "examples" / "01_feedforward" / "lexos.model"
INCLUDE = re.compile(r'^[ \t]*#[ \t]*include[ \t]*[<"]([^>"]+)[>"]', re.M)
DIRECTIVE = re.compile(r"^[ \t]*#[ \t]*(\w+)(.*)$", re.M)


def core_headers(folder: Path) -> set[str]:
    """The headers of the real-time core in ``folder`` (…/include/tendyn): every ``*.hpp`` that reaches no Pinocchio
    header through its includes (tendyn::core, tendyn-cpp.pc: Eigen only)."""
    includes = {p.name: INCLUDE.findall(p.read_text("utf-8")) for p in folder.glob("*.hpp")}

    def needs_pinocchio(name, seen=()):
        for inc in includes[name]:
            own = inc.removeprefix("tendyn/")
            if inc.startswith("pinocchio/") or (own != inc and own not in seen and needs_pinocchio(own, (*seen, name))):
                return True
        return False

    return {name for name in includes if not needs_pinocchio(name)}


def first_include(path: Path) -> str | None:
    """The tendyn header ``path`` includes before anything else (its first directive after ``#pragma once``),
    or None."""
    for line in DIRECTIVE.finditer(path.read_text("utf-8")):
        if line.group(1) == "pragma" and line.group(2).split() == ["once"]:
            continue
        found = INCLUDE.match(line.group(0))
        return found.group(1).removeprefix("tendyn/") if found and found.group(1).startswith("tendyn/") else None
    return None


def header_units(folder: Path, headers: set[str]) -> dict[str, list[str]]:
    """root → the headers its translation unit compiles with nothing before them: the root, its first include,
    that one's first include, … A header whose first line includes another tendyn header compiles that one first,
    with nothing before it, so one unit per header that no other one includes first checks every header alone."""
    first = {h: first_include(folder / h) for h in headers}
    firsts = {f for f in first.values() if f is not None}
    units = {}
    for root in sorted(headers - firsts):
        chain = [root]
        while first[chain[-1]] is not None:
            chain.append(first[chain[-1]])
        units[root] = chain
    return units


@pytest.fixture(scope="module")
def pkg():
    return installed_package()


def _feedforward_python(model: Path) -> str:
    out = run([sys.executable, str(REPO / "examples" / "01_feedforward" / "feedforward.py"), str(model)])
    return out.splitlines()[0]


def _cmake_consumer(tmp: Path, source: str, components: str, prefix_path: str,
                    extra: str = "") -> subprocess.CompletedProcess:
    """Configure a one-file project that finds tendyn with ``components`` (no system paths: only what is given)."""
    (tmp / "main.c").write_text(source)
    (tmp / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.18)\nproject(consumer LANGUAGES C CXX)\n"
        f"find_package(tendyn REQUIRED {components})\n"
        "add_executable(main main.c)\ntarget_link_libraries(main PRIVATE tendyn::tendyn_c)\n" + extra)
    return subprocess.run(["cmake", "-S", str(tmp), "-B", str(tmp / "build"), f"-DCMAKE_PREFIX_PATH={prefix_path}",
                           "-DCMAKE_FIND_USE_CMAKE_SYSTEM_PATH=OFF"], capture_output=True, text=True, env=user_env())


C_MAIN = """#include <stdio.h>
#include "tendyn/c_api.h"
int main(int argc, char** argv) {
  tendyn_transmission* t = NULL;
  char message[256];
  if (tendyn_transmission_load(argv[1], &t, message, sizeof message) != TENDYN_OK) return 1;
  printf("n %d\\n", tendyn_transmission_size(t));
  tendyn_transmission_destroy(t);
  return 0;
}
"""


# ---- the installed files ---------------------------------------------------------------------------------------

def test_package_installs_every_header_library_cmake_and_pkgconfig_file(pkg):
    """The wheel carries every header of include/tendyn (byte for byte), libtendyn_c, the CMake package and the
    two pkg-config files."""
    source = {p.name: p.read_bytes() for p in (REPO / "include" / "tendyn").iterdir()}
    installed = {p.name: p.read_bytes() for p in (pkg.include_dir / "tendyn").iterdir()}
    assert installed == source
    assert pkg.library.is_file()
    for name in ("tendynConfig.cmake", "tendynConfigVersion.cmake", "tendynTargets.cmake", "tendynCoreTargets.cmake",
                 "tendynSimTargets.cmake"):
        assert (pkg.cmake_dir / name).is_file(), name
    assert {p.name for p in pkg.pkgconfig_dir.iterdir()} == {"tendyn.pc", "tendyn-cpp.pc"}


def test_headers_the_docs_name_are_installed(pkg):
    """Every header a doc names (README, docs/: `compensator.hpp`, `tendyn/c_api.h`, …) is in the installed
    include folder."""
    import re

    named = set()
    for doc in [REPO / "README.md", *(REPO / "docs").glob("*.md")]:
        named |= set(re.findall(r"\b([a-z_]+\.hpp|c_api\.h)\b", doc.read_text()))
    assert {"c_api.h", "compensator.hpp", "losses.hpp"} <= named
    assert named <= {p.name for p in (pkg.include_dir / "tendyn").iterdir()}


def test_core_headers_compile_alone_with_the_printed_cpp_flags(pkg, tmp_path):
    """Each Eigen-only header compiles with nothing before it with `tendyn config --cflags --cpp` (syntax only):
    they carry their own includes, and Eigen is where the flags say. The headers include their tendyn headers
    first, so the unit of a header that no other one includes first checks the chain of first includes below it
    (9 units for the 14 headers, 26 s against 39 s for one unit per header; issue 39)."""
    folder = pkg.include_dir / "tendyn"
    headers = core_headers(folder)
    assert {"status.hpp", "routing.hpp", "losses.hpp", "compensator.hpp", "tendons.hpp", "lure.hpp"} <= headers
    assert not headers & {"sim.hpp", "rigid_body.hpp", "regressor.hpp"}
    units = header_units(folder, headers)
    assert {h for chain in units.values() for h in chain} == headers
    flags = tendyn_config("--cflags", "--cpp").split()
    for root in units:
        tu = tmp_path / f"{root}.cpp"
        tu.write_text(f'#include "tendyn/{root}"\nint main() {{ return 0; }}\n')
        run(["c++", "-std=c++17", "-fsyntax-only", str(tu), *flags])


@pytest.mark.parametrize("first", [True, False])
def test_a_header_missing_an_include_fails_its_unit(tmp_path, first):
    """The check above can fail: y.hpp uses std::vector without including <vector>. Included first by x.hpp, it
    is compiled at the head of x's unit (nothing before it) and that unit fails; included after x's own <vector>,
    it is masked there, so it gets a unit of its own, which fails."""
    folder = tmp_path / "include" / "tendyn"
    folder.mkdir(parents=True)
    (folder / "y.hpp").write_text("#pragma once\n#include <cstddef>\ninline std::size_t y() "
                                  "{ return std::vector<int>(3).size(); }\n")
    lines = ['#include "tendyn/y.hpp"', "#include <vector>"]
    (folder / "x.hpp").write_text("#pragma once\n" + "\n".join(lines if first else lines[::-1]) + "\n")
    units = header_units(folder, core_headers(folder))
    assert units == ({"x.hpp": ["x.hpp", "y.hpp"]} if first else {"x.hpp": ["x.hpp"], "y.hpp": ["y.hpp"]})
    failed = []
    for root in units:
        tu = tmp_path / f"{root}.cpp"
        tu.write_text(f'#include "tendyn/{root}"\nint main() {{ return 0; }}\n')
        r = subprocess.run(["c++", "-std=c++17", "-fsyntax-only", str(tu), f"-I{tmp_path / 'include'}"],
                           capture_output=True, text=True)
        if r.returncode != 0:
            failed.append(root)
    assert failed == (["x.hpp"] if first else ["y.hpp"])


# ---- tendyn config ----------------------------------------------------------------------------------------------

def test_config_prints_the_installed_paths(pkg):
    """--cflags / --libs / --cmake-prefix-path / --pkg-config-path point at the installed files; --json holds the
    same lines."""
    assert tendyn_config("--cflags").split() == [f"-I{pkg.include_dir}"]
    assert (pkg.include_dir / "tendyn" / "c_api.h").is_file()
    libs = tendyn_config("--libs").split()
    assert f"-L{pkg.lib_dir}" in libs and f"-Wl,-rpath,{pkg.lib_dir}" in libs and "-ltendyn_c" in libs
    cmake = tendyn_config("--cmake-prefix-path").split(";")
    assert any((Path(p) / "lib" / "cmake" / "tendyn" / "tendynConfig.cmake").is_file() for p in cmake)
    assert any((Path(p) / "share" / "eigen3" / "cmake" / "Eigen3Config.cmake").is_file() for p in cmake)
    pcs = tendyn_config("--pkg-config-path").split(":")
    assert any((Path(p) / "tendyn.pc").is_file() for p in pcs) and any((Path(p) / "eigen3.pc").is_file() for p in pcs)
    doc = json.loads(tendyn_config("--json"))
    assert doc["cflags"] == tendyn_config("--cflags") and doc["libs"] == tendyn_config("--libs")
    assert doc["cmake_prefix_path"] == ";".join(cmake) and doc["library"] == str(pkg.library)


def test_config_starts_without_numpy_the_core_module_or_the_device_packages(pkg):
    """`tendyn config` runs in a build line: it imports neither numpy nor tendyn._core nor the device/sim code."""
    code = ("import sys\nfrom tendyn.cli import main\nassert main(['config', '--cflags', '--libs']) == 0\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('numpy', 'scipy', 'pinocchio') "
            "or m in ('tendyn._core', 'tendyn.device', 'tendyn.sim')))")
    out = run([sys.executable, "-c", code]).splitlines()
    assert out[-1] == "[]", out


@pytest.mark.parametrize("args", [["--cpp"], ["--cflags", "--cmake-prefix-path"], ["--json", "--libs"],
                                  ["--pkg-config-path", "--cmake-prefix-path"], ["--bogus"]])
def test_config_bad_options_exit_2_with_one_line(pkg, args):
    r = subprocess.run([str(TENDYN), "config", *args], capture_output=True, text=True)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.startswith("tendyn: error: ") and r.stderr.count("\n") == 1, r.stderr


# ---- CMake and pkg-config from outside ---------------------------------------------------------------------------

def test_cmake_c_target_needs_no_eigen(pkg, tmp_path):
    """find_package(tendyn COMPONENTS c) with only tendyn's prefix (no Eigen anywhere): configures, builds and
    runs a C program; asking for the C++ core there fails and names Eigen3."""
    r = _cmake_consumer(tmp_path, C_MAIN, "COMPONENTS c", str(pkg.prefix))
    assert r.returncode == 0, r.stdout + r.stderr
    run(["cmake", "--build", str(tmp_path / "build")])
    assert run([str(tmp_path / "build" / "main"), str(LEXOS_MODEL)], env=user_env()).strip() == "n 4"
    (tmp_path / "core").mkdir()
    r = _cmake_consumer(tmp_path / "core", C_MAIN, "COMPONENTS core", str(pkg.prefix))
    assert r.returncode != 0 and "Eigen3" in r.stdout + r.stderr


def test_cmake_components_core_and_sim_give_their_targets(pkg, tmp_path):
    """With the printed prefix path, COMPONENTS core sim find Eigen3 and pinocchio and define tendyn::core and
    tendyn::sim (configure only: compiling against Pinocchio takes minutes); without COMPONENTS tendyn::core
    comes when Eigen3 is found; an unknown component is refused."""
    check = ("foreach(t tendyn::core tendyn::sim)\n  if(NOT TARGET ${t})\n    message(FATAL_ERROR \"no ${t}\")\n"
             "  endif()\nendforeach()\n")
    r = _cmake_consumer(tmp_path, C_MAIN, "COMPONENTS core sim", pkg.cmake_prefix_path(), extra=check)
    assert r.returncode == 0, r.stdout + r.stderr
    (tmp_path / "plain").mkdir()  # no COMPONENTS: tendyn::core comes too, Eigen3 being on the path
    r = _cmake_consumer(tmp_path / "plain", C_MAIN, "", pkg.cmake_prefix_path(),
                        extra=check.replace(" tendyn::sim", ""))
    assert r.returncode == 0, r.stdout + r.stderr
    (tmp_path / "bad").mkdir()
    r = _cmake_consumer(tmp_path / "bad", C_MAIN, "COMPONENTS fortran", pkg.cmake_prefix_path())
    assert r.returncode != 0 and "unknown component 'fortran'" in r.stdout + r.stderr


def test_relocated_package_builds_by_its_own_paths(pkg, tmp_path):
    """A copy of the package (include/, lib/) moved elsewhere: pkg-config and CMake find it there (the .pc files
    and the CMake config compute their prefix from where they are), and the program runs from the copy's
    library (its rpath). The C example only: the paths are what this checks (test_examples builds all four)."""
    moved = tmp_path / "moved" / "tendyn"
    for sub in ("include", "lib"):
        shutil.copytree(pkg.prefix / sub, moved / sub)
    pkg_config_path = ":".join([str(moved / "lib" / "pkgconfig"), *pkg.pkg_config_path().split(":")[1:]])
    cmake_prefix_path = ";".join([str(moved), *pkg.cmake_prefix_path().split(";")[1:]])
    for route, kw in (("pkg-config", {"pkg_config_path": pkg_config_path}),
                      ("cmake", {"cmake_prefix_path": cmake_prefix_path})):
        exes = build(route, tmp_path / route, only=("feedforward_c",), **kw)   # what is checked: the paths
        runpath = run(["readelf", "-d", str(exes["feedforward_c"])])
        assert str(moved / "lib") in runpath and str(pkg.lib_dir) not in runpath, runpath
        assert run([str(exes["feedforward_c"]), str(LEXOS_MODEL)], env=user_env()).splitlines()[0] == \
            _feedforward_python(LEXOS_MODEL)


def test_cmake_install_of_the_plain_build(pkg, tmp_path):
    """`cmake --install` of the plain CMake build (no Python module) into a prefix gives the same package: the
    feedforward examples (the C ABI and the header-only core) build against that prefix through CMake and
    pkg-config and give the Python numbers."""
    from tendyn import c_package

    build_dir, prefix = tmp_path / "build", tmp_path / "prefix"
    made = os.environ.get("TENDYN_CPP_BUILD")
    if made:        # `make test`: the plain build its test-cpp step has just made (the same options, tests added)
        build_dir = Path(made)
    else:
        run(["cmake", "-S", str(REPO), "-B", str(build_dir), "-DTENDYN_BUILD_PYTHON=OFF",
             f"-DPython_EXECUTABLE={sys.executable}", "-DCMAKE_INSTALL_LIBDIR=lib", "-DCMAKE_BUILD_TYPE=Release",
             # Eigen and Pinocchio where `tendyn config` says (`python -m cmeel cmake` prints a ':' list, which
             # CMake reads as one path, when PYTHONPATH holds a second cmeel prefix)
             f"-DCMAKE_PREFIX_PATH={pkg.cmake_prefix_path()}"])
        run(["cmake", "--build", str(build_dir), "-j", "2"])
    run(["cmake", "--install", str(build_dir), "--prefix", str(prefix)])
    plain = c_package.CPackage(prefix=prefix, cmeel_prefix=pkg.cmeel_prefix)
    assert plain.installed()
    assert {p.name for p in (plain.include_dir / "tendyn").iterdir()} == \
        {p.name for p in (pkg.include_dir / "tendyn").iterdir()}
    expected = _feedforward_python(LEXOS_MODEL)
    run_here = ("feedforward_c", "feedforward_cpp")      # the C ABI and the header-only core from that prefix
    for route, kw in (("pkg-config", {"pkg_config_path": plain.pkg_config_path()}),
                      ("cmake", {"cmake_prefix_path": plain.cmake_prefix_path(),
                                 # the prefix's paths are what is checked here (test_examples builds Release):
                                 # no optimisation, feedforward.cpp 6 s of compiler CPU against 12 s (issue 39)
                                 "cmake_build_type": "None"})):
        exes = build(route, tmp_path / route, only=run_here, **kw)
        assert set(exes) == set(run_here) and all(e.exists() for e in exes.values())
        for name in run_here:
            native = run([str(exes[name]), str(LEXOS_MODEL)], env=user_env()).splitlines()[0]
            np.testing.assert_allclose(np.array(native.split()[1:], float), np.array(expected.split()[1:], float),
                                       rtol=1e-14, atol=0)
