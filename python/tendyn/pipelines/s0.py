"""`tendyn pipeline s0`: the S0 workflow on a twin in one call — identification (S1 vs S2, items 3–4 of issue
8), loss decomposition, and the compensation of Fig. 7 with passivity (item 7).

:func:`run_s0` returns one JSON-able document with the keys ``transmissions``, ``decomposition`` and
``compensation`` (and ``hypotheses``, C12, unless quick), with the result objects under ``_figures`` for the
command's report (:func:`tendyn.report.publish`: pipelines write no files).
"""

from __future__ import annotations

import numpy as np

from tendyn.device import compile_device

from .s0_compensation import DEFAULT_UNDERESTIMATION, compensation_summary, fig7_experiment

__all__ = ["drive_identification_parts", "identification_parts", "run_s0"]


def drive_identification_parts(device, seed: int = 0) -> dict:
    """The identification parts of the S0 document for capstan ``[[drives]]``: each drive's planned
    constant-velocity test (:func:`tendyn.protocols.plan_test`, every tree joint inside its limits) on the twin,
    fitted at the motor (S0 eq. 13, :class:`tendyn.ident.friction.TransmissionFriction`). A drive is one cable
    stretch: S1 and S2 are the same move and there is nothing to decompose, so ``transmissions`` has one fit per
    drive (``s2_*`` keys, as for cables) and ``decomposition`` lists the drive itself (τ0 = C_m0 / r_m, ν = ν_m / r_m² at the
    motor radius of :meth:`tendyn.device.schema.SerialDevice.drive_routing_arrays`)."""
    from tendyn.ident.friction import TransmissionFriction
    from tendyn.ident.friction_file import friction_document
    from tendyn.protocols import plan_test
    from tendyn.sim.experiments import constant_velocity

    device = compile_device(device).device
    rows, fits = [], []
    for t, d in enumerate(device.drives, start=1):
        test = plan_test(device, t)
        log = constant_velocity(device, test=test, seed=seed + t).log
        fit = TransmissionFriction(t).fit([log]).result_
        fits.append(fit)
        v = np.asarray(test.speeds, float)
        c0, nu = d.coulomb_motor, d.viscous_motor
        rms_true = float(np.sqrt(np.mean((c0 + nu * v) ** 2)))
        rms_err = float(np.sqrt(np.mean(((fit.coulomb_motor - c0) + (fit.viscous_motor - nu) * v) ** 2)))
        rows.append({"transmission": t, "drive": d.name, "joint": d.joint, "coulomb_motor_true": c0,
                     "viscous_motor_true": nu, "s2_coulomb_motor": fit.coulomb_motor,
                     "s2_viscous_motor": fit.viscous_motor, "s2_error_pct": 100.0 * rms_err / rms_true,
                     "s2_coulomb_error_pct": 100.0 * (fit.coulomb_motor / c0 - 1.0),
                     "s2_viscous_error_pct": 100.0 * (fit.viscous_motor / nu - 1.0)})
    friction = friction_document(device.name, fits)
    from tendyn.device.schema import DRIVE_MOTOR_RADIUS as rm

    branches = [{"transmission": r["transmission"], "branch": 0, "tau0_N": r["s2_coulomb_motor"] / rm,
                 "nu_Ns_m": r["s2_viscous_motor"] / rm ** 2, "p": 1.0, "p_prime": 1.0} for r in rows]
    from tendyn.ident.calibrated import calibrate

    return {"transmissions": rows, "decomposition": branches, "friction": friction,
            "calibrated": calibrate(device, friction),
            "identification": {"strategy_for_compensation": "S2 (a capstan drive: one cable stretch, S1 = S2)",
                               "error_pct": "RMS over the test speeds of the fitted minus true motor friction "
                                            "torque, relative to the true RMS"}}

def identification_parts(device) -> dict:
    """The identification parts of the S0 document: ``transmissions``, ``decomposition`` and ``friction``.

    ``transmissions`` is a list with, per transmission, ``transmission`` (1-based), ``coulomb_motor_true``,
    ``viscous_motor_true``, ``s1_error_pct`` and ``s2_error_pct``; ``decomposition`` the per-branch τ0, ν;
    ``friction`` the identified per-branch losses the compensator then uses (``{"tau0": (n, n), "nu": (n, n)}``,
    0-based ``[transmission, branch]``; see :func:`tendyn.control.transmission_with_friction`), or None for the
    twin's own losses; ``calibrated`` the twin's device with that friction laid over it
    (:func:`tendyn.ident.calibrated.calibrate`: its one loss model, decomposed once, is what the compensator uses).
    """
    from tendyn.ident.calibrated import calibrate
    from tendyn.ident.decomposition import decompose_friction
    from tendyn.ident.friction_file import friction_document

    from .s0_friction import compare_strategies

    device = compile_device(device).device
    cmp = compare_strategies(device)                # S1 and S2 on every transmission (C7, C8)
    v = np.asarray(cmp.speeds_motor, float)
    rows = []
    for t in cmp.transmissions:
        c0, nu = cmp.truth[t]
        rms_true = float(np.sqrt(np.mean((c0 + nu * v) ** 2)))
        row = {"transmission": t, "coulomb_motor_true": c0, "viscous_motor_true": nu}
        for s in ("S1", "S2"):
            f = cmp.fits[(t, s)]
            row[f"{s.lower()}_error_pct"] = 100.0 * cmp.torque_error(t, s) / rms_true
            row[f"{s.lower()}_coulomb_motor"], row[f"{s.lower()}_viscous_motor"] = f.coulomb_motor, f.viscous_motor
            row[f"{s.lower()}_coulomb_error_pct"], row[f"{s.lower()}_viscous_error_pct"] = cmp.errors_pct(t, s)
        rows.append(row)
    fits = [cmp.fits[(t, "S2")] for t in cmp.transmissions]
    friction = friction_document(device.name, fits)       # what identify-friction writes: C_m0, ν, c_L
    cal = calibrate(device, friction)                     # the loss model, from one decomposition (C9)
    dec = decompose_friction(cal)
    branches = [{"transmission": i + 1, "branch": b, "tau0_N": float(dec.tau0_branch[i, b]),
                 "nu_Ns_m": float(dec.nu_branch[i, b]), "p": float(dec.p[i, b]), "p_prime": float(dec.p_prime[i, b])}
                for i, nb in enumerate(dec.branches) for b in range(nb)]
    return {"transmissions": rows, "decomposition": branches, "friction": friction, "calibrated": cal,
            "identification": {"strategy_for_compensation": "S2", "error_pct": "RMS over the test speeds of the "
                               "fitted minus true motor friction torque, relative to the true RMS",
                               "decomposition_max_relative_mismatch": dec.max_mismatch()}}


def run_s0(device, *, quick: bool = False) -> dict:
    """Run the S0 pipeline on ``device`` (a Device, CompiledDevice or bundled name).

    Parameters
    ----------
    quick : fewer runs (no wall, no over-compensation) — for tests

    Returns
    -------
    dict
        ``device``, ``transmissions``, ``decomposition``, ``compensation`` (``reduction_joint1`` (0–1),
        ``rms_joint1_gravity_only``, ``rms_joint1_compensated`` [N·m], ``energy_to_hand_per_cycle`` [J], …);
        ``_table`` (the printed text) and ``_figures`` (name → result object) for the report
        (``tendyn pipeline s0 --report``, :func:`tendyn.report.publish`).
    """
    from .s0_compensation import _device

    compiled = compile_device(_device(device))
    from tendyn.progress import Ticker

    step = Ticker("pipeline s0", expected=3)          # a bar on a terminal, step lines otherwise
    step(f"identification on the {compiled.name} twin")
    drives = not compiled.device.transmissions
    ident = drive_identification_parts(compiled) if drives else identification_parts(compiled)
    step("Fig. 7: free motion with gravity only / with friction compensation")
    # k as with the twin's own losses: the identification carries the load term (c_L), so τ̂0 no longer absorbs
    # the test's load; k = 0.9 gives 72 % and stays passive on L-EXOS (seed 7), where the load-free law needed 0.7.
    # `tendyn export compensator` keeps the safer 0.7 for a lab's device (control.IDENTIFIED_UNDERESTIMATION).
    fig7 = fig7_experiment(ident["calibrated"], underestimation=DEFAULT_UNDERESTIMATION,
                           over=() if quick else (1.2, 1.5), walls=not quick)
    doc = {"device": compiled.name,
           "transmissions": ident["transmissions"],
           "decomposition": ident["decomposition"],
           "compensation": compensation_summary(fig7)}
    hyp = None
    if not quick and not drives:   # C12 on the twin's own losses (S0's cable hypotheses: none for a capstan)
        from .s0_hypotheses import hypotheses_experiment

        step("S0's hypotheses switched one at a time (C12)")
        hyp = hypotheses_experiment(compiled)
        doc["hypotheses"] = hyp.to_dict()
    if "identification" in ident:
        doc["identification"] = ident["identification"]
    doc["_table"] = fig7.table() + ("\n\n" + hyp.table() if hyp is not None else "")
    doc["_figures"] = {"fig7_compensation": fig7, **({"s0_hypotheses": hyp} if hyp is not None else {})}
    return doc
