"""Real data: the EMPS (Janot, Gautier, Brunot 2019, "Data set and reference models of EMPS", a 1-DOF prismatic
electro-mechanical positioning system in closed loop) identified by IDIM-LS, IDIM-IV and DIDIM beside the
published IDIM-LS values (M = 95.1089 kg, Fv = 203.5034 N·s/m, Fc = 20.3935 N, offset −3.1648 N).

The loop: DATA_EMPS.mat itself gives the drive gain gtau [N/V] and the cascade's gains, kp [1/s] (position, P)
and kv [V/(m/s)] (velocity, P): u = kv (kp (qg − qm) − q̇m) [V], force = gtau u. No integral action is given.
The motor position qm [m] and the reference qg [m] are logged at 1 kHz. The device and the log are the suite's
(benchmarks/realdata/emps.py: emps.toml, ``load(shared, loop=True)``).

Interface of the real-data suite: ``rows(shared) -> list[dict]`` with keys dataset, peer, metric, item,
peer_value, tendyn_preset (IDIM-IV), tendyn_default (IDIM-LS), unit, and extra keys tendyn_didim and the σ.
"""

from __future__ import annotations

import contextlib
import io
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import emps  # noqa: E402  (the suite's EMPS loader and device)

PUBLISHED = {"M": (95.1089, "kg"), "Fv": (203.5034, "N·s/m"), "Fc": (20.3935, "N"), "offset": (-3.1648, "N")}


def fits(shared: Path) -> dict:
    """{method: (names, values, stderr)} for ols, iv, didim on DATA_EMPS.mat (the suite's EMPS device and log,
    benchmarks/realdata/emps.py, with the reference and the controller)."""
    from tendyn.ident import IDIM

    log = emps.load(shared, loop=True)
    dev = emps.device()
    out = {}
    for m in ("ols", "iv", "didim"):
        with contextlib.redirect_stderr(io.StringIO()):
            e = IDIM(dev, method=m, velocity_threshold=0.0).fit(log, crossval=False)
        out[m] = (list(e.names_), np.asarray(e.params_), np.asarray(e.stderr_))
    return out


def _pick(names, values, stderr, stem):
    for n, v, s in zip(names, values, stderr):
        if n.rstrip("R").rstrip("0123456789") == stem:
            return float(v), float(s)
    raise KeyError(stem)


STEMS = {"M": None, "Fv": "FV", "Fc": "FS", "offset": "OFFSET"}


def rows(shared: Path) -> list[dict]:
    """One row per published parameter: the published IDIM-LS value, tendyn's IDIM-LS (default), IDIM-IV
    (preset) and DIDIM, with their σ."""
    f = fits(shared)
    out = []
    for item, (pub, unit) in PUBLISHED.items():
        vals = {}
        for m, (names, x, s) in f.items():
            if item == "M":     # the moving mass: the sum of the inertial base parameters of the axis (M1 + IA1)
                mass = [(v, sd) for n, v, sd in zip(names, x, s) if n.rstrip("R").rstrip("0123456789") in ("M", "IA")]
                vals[m] = (sum(v for v, _ in mass), float(np.sqrt(sum(sd * sd for _, sd in mass))))
            else:
                vals[m] = _pick(names, x, s, STEMS[item])
        out.append({"dataset": "emps", "peer": "Janot, Gautier, Brunot 2019 (published IDIM-LS)", "metric": "value",
                    "item": item, "peer_value": pub, "tendyn_preset": vals["iv"][0], "tendyn_default": vals["ols"][0],
                    "unit": unit, "tendyn_didim": vals["didim"][0], "stderr_ls": vals["ols"][1],
                    "stderr_iv": vals["iv"][1], "stderr_didim": vals["didim"][1]})
    return out


if __name__ == "__main__":
    import json

    shared = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parents[3] / "shared"
    print(json.dumps(rows(shared), indent=1))
