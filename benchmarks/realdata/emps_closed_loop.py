"""Real data: the EMPS (Janot, Gautier, Brunot 2019, "Data set and reference models of EMPS", a 1-DOF prismatic
electro-mechanical positioning system in closed loop) identified by IDIM-LS, IDIM-IV and DIDIM beside the
published IDIM-LS values (M = 95.1089 kg, Fv = 203.5034 N·s/m, Fc = 20.3935 N, offset −3.1648 N).

The loop: DATA_EMPS.mat itself gives the drive gain gtau [N/V] and the cascade's gains, kp [1/s] (position, P)
and kv [V/(m/s)] (velocity, P): u = kv (kp (qg − qm) − q̇m) [V], force = gtau u. No integral action is given.
The motor position qm [m] and the reference qg [m] are logged at 1 kHz. This module builds its own minimal
1-DOF prismatic device and log in memory (to be reconciled with the EMPS device/loader of the real-data suite
when it lands: only :func:`emps_device_toml` and :func:`emps_log` would change).

Interface of the real-data suite: ``rows(shared) -> list[dict]`` with keys dataset, peer, metric, item,
peer_value, tendyn_preset (IDIM-IV), tendyn_default (IDIM-LS), unit, and extra keys tendyn_didim and the σ.
"""

from __future__ import annotations

import contextlib
import io
import tempfile
from pathlib import Path

import numpy as np

PUBLISHED = {"M": (95.1089, "kg"), "Fv": (203.5034, "N·s/m"), "Fc": (20.3935, "N"), "offset": (-3.1648, "N")}


def emps_device_toml(mass_guess: float = 100.0) -> str:
    """A horizontal prismatic axis driven directly (ratio 1): the device file's mass is a prior only."""
    return "\n".join([
        "schema = 1", "[device]", 'name = "emps"', 'description = "EMPS linear axis (Janot et al. 2019)"',
        "bandwidth_hz = 5.0", "[kinematics]", 'convention = "mdh"', "gravity = [0.0, 0.0, 0.0]",
        "[[kinematics.joints]]", 'name = "x"', "j = 1", "antecedent = 0", "mu = 1", "sigma = 1", "alpha = 0.0",
        "d = 0.0", "r = 0.0", "lower = -1.0", "upper = 1.0", f"mass = {mass_guess!r}", "com = [0.0, 0.0, 0.0]",
        "inertia = [0.01, 0.01, 0.01, 0.0, 0.0, 0.0]", "[[actuators]]", "joint = 1", "ratio = 1.0"]) + "\n"


def emps_log(mat: Path):
    """The tendyn log of DATA_EMPS.mat (q_motor_1 = qm [m], torque_motor_1 = gtau·vir [N], q_ref_1 = qg [m]) and
    the controller the file gives."""
    import scipy.io

    from tendyn.ident.closed_loop import LoopController
    from tendyn.io.logs import make_log

    d = scipy.io.loadmat(mat)
    t, qm, qg, vir = (np.ravel(d[k]).astype(float) for k in ("t", "qm", "qg", "vir"))
    gtau, kp, kv = (float(np.ravel(d[k])[0]) for k in ("gtau", "kp", "kv"))
    rate = 1.0 / float(np.median(np.diff(t)))
    t = np.arange(t.size) / round(rate)
    ctrl = LoopController(kp=(kv * kp,), kd=(kv,), ki=(0.0,), velocity_feedforward=False, gain=(gtau,),
                          label=f"EMPS cascade P-P (kp {kp:g} 1/s, kv {kv:g} V/(m/s), gtau {gtau:.6g} N/V)")
    log = make_log({"time": t, "q_motor_1": qm, "torque_motor_1": gtau * vir, "q_ref_1": qg}, device="emps",
                   rate_hz=float(round(rate)), seed=None, experiment="emps",
                   options={"controller": ctrl.to_dict()},
                   units={"q_motor_1": "m", "torque_motor_1": "N", "q_ref_1": "m"})
    return log


def fits(shared: Path) -> dict:
    """{method: (names, values, stderr)} for ols, iv, didim on DATA_EMPS.mat."""
    from tendyn.device import load_device
    from tendyn.ident import IDIM

    mat = Path(shared) / "external-data" / "emps" / "DATA_EMPS.mat"
    log = emps_log(mat)
    with tempfile.TemporaryDirectory() as tmp:
        f = Path(tmp) / "emps.toml"
        f.write_text(emps_device_toml())
        dev = load_device(f)
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
    import sys

    shared = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parents[3] / "shared"
    print(json.dumps(rows(shared), indent=1))
