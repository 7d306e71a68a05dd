"""Where the installed C/C++ package is, and the compiler and build-system lines that use it.

The wheel carries the C ABI and the header-only C++ core inside the Python package (CMakeLists.txt installs
them; docs/c-package.md)::

    site-packages/tendyn/include/tendyn/*.h, *.hpp
    site-packages/tendyn/lib/libtendyn_c.so
    site-packages/tendyn/lib/cmake/tendyn/tendynConfig.cmake   (find_package(tendyn))
    site-packages/tendyn/lib/pkgconfig/tendyn.pc, tendyn-cpp.pc

The C++ headers need Eigen 3: the cmeel-eigen wheel (``pip install 'tendyn[cpp]'``; the build of tendyn pulls
it too) puts it in ``site-packages/cmeel.prefix``, which also holds Pinocchio (the ``pin`` wheel) for the
simulator headers. Standard library only: ``tendyn config`` must answer without numpy or the C++ module.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

LIBRARY = "libtendyn_c.so"
CMEEL_PREFIX = "cmeel.prefix"  # the folder the cmeel wheels (Eigen, Pinocchio) install their prefix into
SYSTEM_EIGEN = Path("/usr/include/eigen3")  # Debian's libeigen3-dev, used when no cmeel-eigen is installed


@dataclass(frozen=True)
class CPackage:
    """Paths of an installed tendyn C/C++ package (absolute)."""

    prefix: Path                # the install root: include/, lib/ below it
    cmeel_prefix: Path | None   # site-packages/cmeel.prefix (Eigen, Pinocchio), if there is one

    @property
    def include_dir(self) -> Path:
        return self.prefix / "include"

    @property
    def lib_dir(self) -> Path:
        return self.prefix / "lib"

    @property
    def library(self) -> Path:
        return self.lib_dir / LIBRARY

    @property
    def cmake_dir(self) -> Path:
        return self.lib_dir / "cmake" / "tendyn"

    @property
    def pkgconfig_dir(self) -> Path:
        return self.lib_dir / "pkgconfig"

    @property
    def eigen_include_dir(self) -> Path | None:
        """Eigen 3's include folder for the C++ headers: the cmeel-eigen wheel's, else the system's, else None."""
        for d in ([self.cmeel_prefix / "include" / "eigen3"] if self.cmeel_prefix else []) + [SYSTEM_EIGEN]:
            if (d / "Eigen" / "Core").is_file():
                return d
        return None

    def installed(self) -> bool:
        return self.library.is_file() and (self.include_dir / "tendyn" / "c_api.h").is_file()

    # ---- the lines a user pastes --------------------------------------------------------------------------
    def cflags(self, cpp: bool = False) -> list[str]:
        """``-I`` flags: tendyn's headers, and Eigen's with ``cpp`` (the C++ headers need it)."""
        flags = [f"-I{self.include_dir}"]
        if cpp:
            eigen = self.eigen_include_dir
            if eigen is None:
                raise LookupError("Eigen 3 is not installed: `pip install 'tendyn[cpp]'` (the cmeel-eigen wheel) "
                                  "or the system's (Debian: libeigen3-dev)")
            flags.append(f"-I{eigen}")
        return flags

    def libs(self) -> list[str]:
        """Link flags of the C ABI; the rpath lets the program find libtendyn_c where it is installed."""
        return [f"-L{self.lib_dir}", f"-Wl,-rpath,{self.lib_dir}", "-ltendyn_c"]

    def cmake_prefix_path(self) -> str:
        """CMAKE_PREFIX_PATH (;-separated) for find_package(tendyn) and its Eigen3 / pinocchio dependencies."""
        return ";".join(str(p) for p in (self.prefix, self.cmeel_prefix) if p is not None)

    def pkg_config_path(self) -> str:
        """PKG_CONFIG_PATH (:-separated) for tendyn.pc, tendyn-cpp.pc and the eigen3.pc it requires."""
        dirs = [self.pkgconfig_dir]
        if self.cmeel_prefix is not None:
            dirs += [self.cmeel_prefix / "share" / "pkgconfig", self.cmeel_prefix / "lib" / "pkgconfig"]
        return ":".join(str(d) for d in dirs if d.is_dir())


def find() -> CPackage:
    """The package installed with this ``tendyn`` (inside the Python package) and the cmeel prefix beside it."""
    prefix = Path(__file__).resolve().parent
    candidates = [prefix.parent] + [Path(p) for p in sys.path if p]
    cmeel = next((c / CMEEL_PREFIX for c in candidates if (c / CMEEL_PREFIX).is_dir()), None)
    return CPackage(prefix=prefix, cmeel_prefix=cmeel)
