"""Solve one conic problem with SCS 1.2.6, WPI's solver, in its own environment (build/scs126/venv, made by
build_scs126.sh): ``python _scs126_solve.py PROBLEM.npz SOLUTION.npz`` with WPI's settings (main_mtm.ipynb's log:
sparse-indirect (CG), eps 1e-3, alpha 1.5, max_iters 10000, normalize 1, scale 1). PROBLEM.npz holds the SCS
standard form as cvxpy writes it (A in CSC parts, b, c, the cone sizes zero, nonneg, soc, psd); SOLUTION.npz the
raw x, y, s and the info with SCS 3's key names (what cvxpy's SCS interface reads back). Runs with NumPy/SciPy
only: no tendyn import here (this environment has none)."""

from __future__ import annotations

import json
import sys

import numpy as np
import scipy.sparse as sp

SETTINGS = {"eps": 1e-3, "alpha": 1.5, "max_iters": 10000, "normalize": True, "scale": 1.0, "use_indirect": True,
            "verbose": True}
"""WPI's SCS settings (the notebook's solver log, cell 95)."""


def main(src: str, dst: str) -> None:
    import scs

    d = np.load(src)
    A = sp.csc_matrix((d["A_data"], d["A_indices"], d["A_indptr"]), shape=tuple(d["A_shape"]))
    cone = {"f": int(d["zero"]), "l": int(d["nonneg"]), "q": [int(v) for v in d["soc"]],
            "s": [int(v) for v in d["psd"]]}
    opts = dict(SETTINGS, **json.loads(str(d["settings"]))) if "settings" in d else SETTINGS
    sol = scs.solve({"A": A, "b": d["b"], "c": d["c"]}, cone, **opts)
    info = sol["info"]
    out = {"status_val": info["statusVal"], "status": info["status"], "iter": info["iter"], "pobj": info["pobj"],
           "dobj": info["dobj"], "res_pri": info["resPri"], "res_dual": info["resDual"], "gap": info["relGap"],
           "solve_time": info["solveTime"], "setup_time": info["setupTime"], "scs_version": scs.__version__}
    np.savez(dst, x=sol["x"], y=sol["y"], s=sol["s"], info=json.dumps(out))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
