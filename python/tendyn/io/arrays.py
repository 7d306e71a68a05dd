"""Named arrays of MATLAB (.mat v4/v5/v7 through ``scipy.io``, v7.3 through ``h5py``) and HDF5 (.h5, .hdf5) files.

An import map (``tendyn.io.importer``) names a variable (``column = "qm"``) or an HDF5 dataset path
(``column = "/run1/q"``), and for a 2-D array the 1-based column of the signal (``index = 3``). A MATLAB struct
field is named with dots or slashes (``column = "data.q"``). Arrays are samples × signals as MATLAB shows them:
a v7.3 file stores MATLAB's column-major arrays transposed, and is read back in MATLAB's orientation; a plain HDF5
dataset is read as written (rows are samples).

Every problem raises :class:`ValueError` with a one-line message (the importer adds the map, the entry and the file).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["ArrayFile", "ARRAY_SUFFIXES"]

ARRAY_SUFFIXES = (".mat", ".h5", ".hdf5")
_MAT73_MAGIC = b"MATLAB 7.3 MAT-file"


class ArrayFile:
    """A .mat or HDF5 file opened once; :meth:`get` returns one signal as a 1-D float64 array.

    Parameters
    ----------
    path : pathlib.Path
        A ``.mat`` file (any MATLAB version) or an HDF5 file (``.h5``, ``.hdf5``).
    """

    def __init__(self, path: Path):
        self.path = Path(path)
        try:
            head = self.path.open("rb").read(128)
        except OSError as exc:
            raise ValueError(f"cannot read: {exc.strerror or exc}") from None
        self.suffix = self.path.suffix.lower()
        self.matlab = self.suffix == ".mat"
        self.hdf5 = head.startswith(b"\x89HDF") or _MAT73_MAGIC in head[:len(_MAT73_MAGIC) + 8]
        self._vars: dict | None = None
        self._h5 = None
        if self.hdf5:
            import h5py

            try:
                self._h5 = h5py.File(self.path, "r")
            except OSError as exc:
                raise ValueError(f"not a readable HDF5 file ({exc})") from None
        elif self.matlab:
            import scipy.io

            try:
                self._vars = scipy.io.loadmat(self.path, simplify_cells=True)
            except (ValueError, TypeError, OSError, NotImplementedError) as exc:
                raise ValueError(f"not a readable MATLAB file ({str(exc).splitlines()[0] if str(exc) else exc})") \
                    from None
        else:
            raise ValueError("not an HDF5 file (no HDF5 signature in its first bytes)")

    def close(self) -> None:
        if self._h5 is not None:
            self._h5.close()
            self._h5 = None

    def names(self) -> list[str]:
        """The numeric variables (MATLAB v5) or dataset paths (HDF5, MATLAB v7.3) of the file."""
        if self._vars is not None:
            out = []

            def walk(prefix, d):
                for k, v in d.items():
                    if k.startswith("__"):
                        continue
                    if isinstance(v, dict):
                        walk(f"{prefix}{k}.", v)
                    elif isinstance(v, np.ndarray) and v.dtype.kind in "iufb" or isinstance(v, (int, float)):
                        out.append(prefix + k)
            walk("", self._vars)
            return out
        import h5py

        out = []
        self._h5.visititems(lambda n, o: out.append(n) if isinstance(o, h5py.Dataset) and o.dtype.kind in "iufb"
                            and not n.startswith("#refs#") else None)
        return out

    def _raw(self, name: str):
        if self._vars is not None:
            node = self._vars
            for part in name.replace("/", ".").split("."):
                if not isinstance(node, dict) or part not in node or part.startswith("__"):
                    raise KeyError(name)
                node = node[part]
            return np.asarray(node)
        key = name.replace(".", "/") if self.matlab else name
        key = key.lstrip("/")
        if not key or key not in self._h5:
            raise KeyError(name)
        import h5py

        obj = self._h5[key]
        if not isinstance(obj, h5py.Dataset):
            raise ValueError(f"{name!r} is a group, not a dataset (datasets: {', '.join(self.names()[:12])})")
        arr = obj[()]
        if self.matlab:                     # v7.3: MATLAB's column-major array, stored transposed
            arr = np.asarray(arr).T
        return np.asarray(arr)

    def get(self, name: str, index: int | None) -> np.ndarray:
        """Variable or dataset ``name`` as a 1-D float64 array; ``index`` (1-based) picks a column of a 2-D one."""
        try:
            arr = self._raw(name)
        except KeyError:
            known = self.names()
            shown = ", ".join(known[:20]) + (", …" if len(known) > 20 else "")
            raise ValueError(f"no variable {name!r} in {self.path.name} (variables: {shown or 'none'})") from None
        if arr.dtype.kind not in "iufb":
            raise ValueError(f"{name!r} is not numeric ({arr.dtype}) in {self.path.name}")
        if arr.ndim == 2 and 1 in arr.shape and index is None:
            arr = arr.reshape(-1)
        if arr.ndim == 0:
            raise ValueError(f"{name!r} is a scalar in {self.path.name}, not a signal")
        if arr.ndim == 1:
            if index is not None and index != 1:
                raise ValueError(f"index = {index} but {name!r} is a vector ({arr.size} samples) in "
                                 f"{self.path.name}: remove index")
            return arr.astype(np.float64)
        if arr.ndim != 2:
            raise ValueError(f"{name!r} has {arr.ndim} dimensions {arr.shape} in {self.path.name}: a signal is a "
                             "vector or a column of a samples × signals matrix")
        if index is None:
            raise ValueError(f"{name!r} is a {arr.shape[0]}×{arr.shape[1]} matrix in {self.path.name}: give "
                             f"index = 1..{arr.shape[1]} (its column)")
        if index > arr.shape[1]:
            raise ValueError(f"index = {index} but {name!r} has {arr.shape[1]} columns in {self.path.name}")
        return arr[:, index - 1].astype(np.float64)
