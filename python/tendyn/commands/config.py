"""`tendyn config [--cflags] [--libs] [--cpp] | --cmake-prefix-path | --pkg-config-path [--json]`: the compile
and build-system lines of the installed C/C++ package (:mod:`tendyn.c_package`, docs/c-package.md).

    cc main.c $(tendyn config --cflags --libs)
    c++ -std=c++17 main.cpp $(tendyn config --cflags --cpp)
    cmake -S . -B build -DCMAKE_PREFIX_PATH="$(tendyn config --cmake-prefix-path)"
    PKG_CONFIG_PATH="$(tendyn config --pkg-config-path)" pkg-config --cflags --libs tendyn

It answers in a few tens of milliseconds: :func:`tendyn.cli.main` parses it without importing numpy, the C++
module or the device and simulator packages (standard library only here).
"""

from __future__ import annotations

import json

from tendyn.errors import UsageError

PATH_OPTIONS = ("cmake_prefix_path", "pkg_config_path")


def register(subparsers) -> None:
    p = subparsers.add_parser("config", help="compile line and CMake / pkg-config paths of the C/C++ package")
    p.add_argument("--cflags", action="store_true", help="-I flags of the headers")
    p.add_argument("--libs", action="store_true", help="link flags of libtendyn_c (with its rpath)")
    p.add_argument("--cpp", action="store_true", help="with --cflags: also Eigen's -I (the C++ headers need it)")
    p.add_argument("--cmake-prefix-path", action="store_true",
                   help="CMAKE_PREFIX_PATH (;-separated) for find_package(tendyn) and Eigen3")
    p.add_argument("--pkg-config-path", action="store_true",
                   help="PKG_CONFIG_PATH (:-separated) for tendyn.pc, tendyn-cpp.pc and eigen3.pc")
    p.add_argument("--json", action="store_true", help="print every path and line as one JSON document")
    p.set_defaults(func=run)


def run(args) -> int:
    from tendyn import c_package

    pkg = c_package.find()
    if not pkg.installed():
        raise UsageError(f"the C/C++ package is not installed in {pkg.prefix} (no lib/{c_package.LIBRARY}): "
                         "install the tendyn wheel (make install, pip install)")
    paths = [name for name in PATH_OPTIONS if getattr(args, name)]
    flags = args.cflags or args.libs
    if len(paths) + bool(flags) + args.json > 1:
        raise UsageError("give either --cflags/--libs, --cmake-prefix-path, --pkg-config-path or --json")
    if args.cpp and not args.cflags:
        raise UsageError("goes with --cflags (the C++ headers are header-only: no library to link)", "cpp")
    if paths:
        print(getattr(pkg, paths[0])())
    elif flags:
        print(" ".join(_flags(pkg, args.cflags, args.libs, args.cpp)))
    elif args.json:
        print(json.dumps(_document(pkg), indent=2))
    else:
        print(_table(_document(pkg)))
    return 0


def _flags(pkg, cflags: bool, libs: bool, cpp: bool) -> list[str]:
    try:
        return (pkg.cflags(cpp) if cflags else []) + (pkg.libs() if libs else [])
    except LookupError as exc:
        raise UsageError(str(exc), "cpp") from None


def _document(pkg) -> dict:
    eigen = pkg.eigen_include_dir
    return {
        "prefix": str(pkg.prefix),
        "include_dir": str(pkg.include_dir),
        "library": str(pkg.library),
        "cmake_dir": str(pkg.cmake_dir),
        "pkgconfig_dir": str(pkg.pkgconfig_dir),
        "eigen_include_dir": None if eigen is None else str(eigen),
        "cflags": " ".join(pkg.cflags()),
        "libs": " ".join(pkg.libs()),
        "cmake_prefix_path": pkg.cmake_prefix_path(),
        "pkg_config_path": pkg.pkg_config_path(),
    }


def _table(doc: dict) -> str:
    rows = [(key.replace("_", " "), "(not found: pip install 'tendyn[cpp]')" if value is None else value)
            for key, value in doc.items()]
    width = max(len(k) for k, _ in rows)
    lines = [f"{k:<{width}}  {v}" for k, v in rows]
    lines += ["", "C:      cc main.c $(tendyn config --cflags --libs)",
              "C++:    c++ -std=c++17 main.cpp $(tendyn config --cflags --cpp)",
              '        (C ABI from C++: add $(tendyn config --libs))',
              'CMake:  cmake -DCMAKE_PREFIX_PATH="$(tendyn config --cmake-prefix-path)" ...; '
              "find_package(tendyn REQUIRED COMPONENTS c core)",
              'pkg-config: PKG_CONFIG_PATH="$(tendyn config --pkg-config-path)" pkg-config --cflags --libs tendyn']
    return "\n".join(lines)
