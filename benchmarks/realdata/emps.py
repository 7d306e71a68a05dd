"""EMPS (Janot, Gautier & Brunot, "Data set and reference models of EMPS", 2019): one prismatic axis, the IDIM-LS
of their Script_IDIM_LS.m on DATA_EMPS.mat, validated on DATA_EMPS_PULSES.mat. tendyn with ``--treatment janot``
reproduces it; tendyn's defaults are measured against it on the same numbers and on the record it did not fit
(PULSES, relative error by Janot's metric: the validation log treated like the identification one, rows 50 on,
decimated)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
DEVICE = HERE / "emps.toml"
PEER = "Janot, Gautier & Brunot 2019 (Script_IDIM_LS.m)"
PUBLISHED = {"M1R": (95.1089, "kg"), "FV1": (203.5034, "N·s/m"), "FS1": (20.3935, "N"), "OFFSET1": (-3.1648, "N")}
"""Their published IDIM-LS (PROVENANCE.md of the data)."""
PUBLISHED_FIT_ERROR = 4.0834      # % relative error on DATA_EMPS
PUBLISHED_PULSES_ERROR = 5.9824   # % relative error on DATA_EMPS_PULSES


def folder(shared: Path) -> Path:
    f = Path(shared) / "external-data" / "emps"
    if not (f / "DATA_EMPS.mat").is_file():
        raise FileNotFoundError(str(f / "DATA_EMPS.mat"))
    return f


def load(shared: Path, name: str = "DATA_EMPS", loop: bool = False):
    """A .mat record as a tendyn log: q_motor_1 = qm [m], torque_motor_1 = gtau · vir [N], 1 kHz. ``loop``: also
    the reference q_ref_1 = qg [m] and, in meta.options.controller, the cascade the file gives (kp [1/s] position
    P, kv [V/(m/s)] velocity P, gtau [N/V]: u = kv (kp (qg − qm) − q̇m), force = gtau u), for IDIM-IV and DIDIM."""
    import scipy.io

    from tendyn.io import make_log

    d = scipy.io.loadmat(folder(shared) / f"{name}.mat")
    gtau = float(d["gtau"].ravel()[0])
    cols = {"time": d["t"].ravel(), "q_motor_1": d["qm"].ravel(), "torque_motor_1": d["vir"].ravel() * gtau}
    units = {"q_motor_1": "m", "torque_motor_1": "N"}
    options = None
    if loop:
        from tendyn.ident.closed_loop import LoopController

        kp, kv = (float(d[k].ravel()[0]) for k in ("kp", "kv"))
        ctrl = LoopController(kp=(kv * kp,), kd=(kv,), ki=(0.0,), velocity_feedforward=False, gain=(gtau,),
                              label=f"EMPS cascade P-P (kp {kp:g} 1/s, kv {kv:g} V/(m/s), gtau {gtau:.6g} N/V)")
        cols["q_ref_1"], units["q_ref_1"], options = d["qg"].ravel(), "m", {"controller": ctrl.to_dict()}
    return make_log(cols, device="emps", rate_hz=1000.0, seed=0, experiment="exciting", options=options,
                    units=units)


def device():
    from tendyn.device import load_device

    return load_device(DEVICE)


def fit(log, treatment="tendyn", **kw):
    from tendyn.ident import IDIM

    return IDIM(device(), treatment=treatment, **kw).fit(log, crossval=False)


def janot_error(est, log) -> float:
    """Relative error ‖Y − W X‖ / ‖Y‖ [%] of the fitted parameters on a log treated as Janot's script treats
    it (rows 50 on, MATLAB's decimate by 10): the metric of their published 4.0834 % and 5.9824 %."""
    from tendyn.ident import IDIM

    ob = IDIM(device(), treatment="janot")
    Y, W, _, _, _ = ob.observations(log)
    m = ob._model()
    x = m.parameter_vector(est.identified_model().params)
    return float(100 * np.linalg.norm(Y - W @ x) / np.linalg.norm(Y))


def measured(shared: Path) -> dict:
    """Both fits and their errors (the numbers the rows and the tests read)."""
    log, pulses = load(shared), load(shared, "DATA_EMPS_PULSES")
    out = {}
    for key, kw in (("janot", {"treatment": "janot"}), ("default", {})):
        est = fit(log, **kw)
        out[key] = {"params": dict(zip(est.names_, map(float, est.params_))), "est": est,
                    "fit_error": janot_error(est, log), "pulses_error": janot_error(est, pulses),
                    "pulses_validate": float(100 * np.linalg.norm(est.predict(pulses).relative_error))}
    return out


def rows(shared: Path) -> list[dict]:
    m = measured(shared)
    out = []
    for name, (value, unit) in PUBLISHED.items():
        out.append({"dataset": "emps", "peer": PEER, "metric": "parameter", "item": name, "peer_value": value,
                    "tendyn_preset": m["janot"]["params"][name], "tendyn_default": m["default"]["params"][name],
                    "unit": unit})
    for item, value, key in (("DATA_EMPS (fitted)", PUBLISHED_FIT_ERROR, "fit_error"),
                             ("DATA_EMPS_PULSES (not fitted)", PUBLISHED_PULSES_ERROR, "pulses_error")):
        out.append({"dataset": "emps", "peer": PEER, "metric": "relative error (Janot's metric)", "item": item,
                    "peer_value": value, "tendyn_preset": m["janot"][key], "tendyn_default": m["default"][key],
                    "unit": "%"})
    return out


def figures(shared: Path) -> list:
    est = fit(load(shared))
    return [("tendyn's default model predicting DATA_EMPS_PULSES (not fitted)",
             est.predict(load(shared, "DATA_EMPS_PULSES")))]
