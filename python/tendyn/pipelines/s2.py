"""S2 end to end on the CEA branch twin (issue 10): capstan stiffness from blocked-link tests (C31, C32), the
friction protocol (C33–C35, Table 3), exciting trajectories and cond(W) (C37), Table 4 with its statistics (C36,
C38, C39), the cross-validation (C40), then from the identified values the operational maps (C41–C45,
:mod:`tendyn.analysis.operational`) and the compensation (C46, :mod:`tendyn.pipelines.s2_compensation`).
:func:`run_s2` returns one :class:`S2Report` whose ``summary`` is the JSON contract of ``tendyn pipeline s2``.

Order (S2 §V–VI): the blocked tests give K per drive, K and the "CAD" inertia give the bandwidth (≈ 20 Hz),
the identification band is a decade below (0.1–2 Hz), and that band sets both the exciting trajectories and
the data treatment (Gautier: Butterworth at 5 × 2 Hz, parallel filter and decimation to 20 Hz), so the
capstan resonance stays out of W and Y and the rigid model of eq. (12) holds. The estimator reads only the
logs (encoders, measured torques); S2's printed values are used only to lay the results beside them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from tendyn.results import Result, format_table

__all__ = ["S2Report", "run_s2", "TABLE4_PAPER", "S2_MINIMUM_NAMES", "paper_name", "optimise_exciting",
           "calibrate_current_noise", "PAPER_ROWS", "VELOCITY_THRESHOLD"]

TABLE4_PAPER = {"ZZ1R": (0.0510, 0.4480), "MY1R": (-0.0260, 1.200), "FV1": (0.023, 22.000), "FS1": (0.1179, 0.7823),
                "XX2R": (-0.0209, 0.8488), "ZZ2R": (0.0295, 0.3538), "MX2R": (-0.0225, 0.7660),
                "FV2R": (0.032, 21.000), "FS2": (0.1240, 0.8120), "OFFSET2": (0.0200, 3.3470),
                "XX3R": (-0.0110, 1.2500), "ZZ3R": (0.0130, 0.4320), "MX3R": (-0.0310, 0.4130),
                "FV5R": (0.031, 20.000), "FS5R": (0.1152, 1.2580), "OFFSET5": (0.0300, 1.100)}
"""S2 Table 4 [SEED] (decimal commas read as points, ERRATA): name → (value [SI], relative deviation [%])."""

_OURS_FROM_TABLE4 = {"FV2R": "FV2", "FV5R": "FV5", "FS5R": "FS5"}
"""Table 4 names whose base parameter carries no "R" here (no passive-joint friction in the model, C34)."""

S2_MINIMUM_NAMES = {"MY3R": "MY3", "FV5": "FV5R", "FS5": "FS5R"}
"""Our base-parameter names → S2's list of 29 (§V-D) where they differ (S2's MY3 is MY3R here only because
the massless cut-joint link 7 sits in the tree). MY4 is a base parameter of the twin S2 does not list."""

PAPER_ROWS = 15000
"""Rows of S2's W (15000 × 16): %σ are also reported scaled to this length (σ ∝ 1/√r)."""

VELOCITY_THRESHOLD = 0.15
"""Rows of a joint slower than this [rad/s] are left out of W (IDIM's velocity threshold). The friction law of
S2 eq. (15) is validated by the friction protocol from 0.1 rad/s up; below, the twin's dry friction — at the
motor, behind the cable spring — sticks at each reversal while the spring winds up by 2 F_c / K (S2 Fig. 4),
and the encoder-derived q̈ is wrong there. Measured on the twin (90 s, calibrated noise): with 2 % of the peak
speed (≈ 0.03 rad/s) ZZ3R is biased +5.6 % (5.7σ), ZZ2R +2.1 % (4.8σ), FS5 −1.3 % (3.3σ); with 0.15 rad/s every
Table 4 parameter is within 2.3σ and cond(W) is 48."""


def paper_name(name: str) -> str:
    """S2's name of one of our base parameters (S2 §V-D list; "MY4 (not in S2)" for the extra one)."""
    if name == "MY4":
        return "MY4 (not in S2's list)"
    return S2_MINIMUM_NAMES.get(name, name)


def table4_names() -> list[str]:
    """Our base-parameter names of S2 Table 4's 16 parameters, in Table 4's order."""
    return [_OURS_FROM_TABLE4.get(n, n) for n in TABLE4_PAPER]


@dataclass(eq=False)
class S2Report(Result):
    """Everything :func:`run_s2` computed; ``summary`` is the JSON contract of ``tendyn pipeline s2``.
    ``stiffness_motor`` [N·m/rad] per drive (identified, motor side) and ``params`` (Table 4 model) are what
    the operational maps (C41–C45) and the compensation (C46) take."""

    summary: dict
    figures: dict = field(default_factory=dict)
    stiffness_motor: list = field(default_factory=list)
    params: list = field(default_factory=list)

    reading = ('The cross-validation figure of the S2 run: measured and predicted torques on the log that was not '
               'fitted.')

    def _draw(self, ax) -> None:
        self.figures["crossval"].plot(ax)

    def to_dict(self) -> dict:
        return self.summary

    def table(self) -> str:
        s = self.summary
        out = [format_table(("Drive", "K [N·m/rad]", "%σ", "B", "offset"),
                            [(d["drive"], f"{d['K']:.4g}", f"{d['rel_stderr_pct']:.3g}", f"{d['B']:.3g}",
                              f"{d['offset']:.3g}") for d in s["stiffness"]],
                            title="Capstan stiffness from blocked links (S2 Table 2), motor side"),
               f"bandwidth {s['bandwidth_hz']:.3g} Hz -> identification band {s['identification_band_hz'][0]:g}-"
               f"{s['identification_band_hz'][1]:.3g} Hz", "", s["friction_table"], "",
               format_table(*_table4(s["table4"], s.get("paper_twin", True)),
                            title=f"S2 Table 4: W {s['n_rows']} x {len(s['table4'])}, cond(W) = {s['cond_exciting']:.3g}"),
               "", format_table(("Omitted", "identified", "%σ"),
                                [(o["name"], f"{o['value']:.3g}", f"{o['rel_stderr_pct']:.3g}") for o in s["omitted"]],
                                title=f"parameters S2 omits, identified in the full model (cond {s['cond_full']:.4g})"),
               f"removing them moves the Table 4 parameters by at most {s['omitted_perturbation_max_sigma']:.2f} σ",
               "", "cross-validation (trajectory not used for the fit), relative error per joint: " + ", ".join(
                   f"joint {j}: {100 * e:.2f} %" for j, e in zip(s["crossval"]["joints"], s["crossval"]["rel_error"]))]
        if "maps" in s:
            m = s["maps"]
            lo, hi = m["stiffness_range_N_per_m"]
            out += ["", f"operational maps from the identified values (C41–C45): max apparent mass "
                        f"{1e3 * m['max_apparent_mass_kg']:.0f} g, stiffness {lo:.0f}–{hi:.0f} N/m, max dry friction "
                        f"{m['max_dry_friction_N']:.3f} N"]
        if "compensation" in self.figures:
            out += ["", self.figures["compensation"].table()]
        return "\n".join(out)


def _table4(rows, paper: bool):
    """Headers and rows of Table 4: with S2's printed values and σ beside ours on S2's twin only."""
    if paper:
        return (("Parameter", "S2", "identified", "%σ", "%σ at 15000 rows", "S2 %σ", "within 3σ"),
                [(r["name"], f"{r['paper']:.4g}", f"{r['identified']:.4g}", f"{r['rel_stderr_pct']:.3g}",
                  f"{r['rel_stderr_pct_at_paper_rows']:.3g}", f"{r['paper_rel_stderr_pct']:.3g}",
                  "yes" if r["within_3_sigma"] else "NO") for r in rows])
    return (("Parameter", "identified", "%σ", "%σ at 15000 rows"),
            [(r["name"], f"{r['identified']:.4g}", f"{r['rel_stderr_pct']:.3g}",
              f"{r['rel_stderr_pct_at_paper_rows']:.3g}") for r in rows])


@dataclass(eq=False)
class CrossValidation(Result):
    """Measured vs estimated joint torques on a trajectory not used for the fit (S2 Fig. 7)."""

    time: np.ndarray
    y: np.ndarray
    y_hat: np.ndarray
    rows: np.ndarray
    joints: list
    show_joint: int = 5

    def rel_error(self) -> list[float]:
        return [float(np.linalg.norm(self.y[self.rows == j] - self.y_hat[self.rows == j])
                      / np.linalg.norm(self.y[self.rows == j])) for j in range(len(self.joints))]

    def to_dict(self) -> dict:
        return {"joints": self.joints, "rel_error": self.rel_error(), "n_rows": int(self.y.size)}

    def table(self) -> str:
        return format_table(("Joint", "relative error %"), [(j, f"{100 * e:.3g}") for j, e in
                                                            zip(self.joints, self.rel_error())],
                            title="cross-validation")

    reading = ('Measured (colour) and predicted (black) joint torques on the log that was not used for the fit; '
               'where they part, the identified model misses the motion.')

    def _draw(self, ax) -> None:
        j = self.joints.index(self.show_joint)
        sel = self.rows == j
        ax.plot(self.time[sel], self.y[sel], lw=0.9, label="measured")
        ax.plot(self.time[sel], self.y_hat[sel], "k--", lw=0.9, label="estimated (Table 4 parameters)")
        ax.set_xlabel("time [s]")
        ax.set_ylabel(f"torque of joint {self.show_joint} [N·m]")
        ax.set_title(f"cross-validation, forearm drive (joint {self.show_joint}): S2 Fig. 7")
        ax.legend(fontsize=7)


def optimise_exciting(device, design, parameters, duration: float, rate_hz: float = 20.0, maxfev: int = 200,
                      seed: int = 0):
    """Lower cond(W) of an exciting design by moving its phases only (amplitudes, frequencies, centre — hence
    the joint, speed and torque limits the design satisfies — unchanged). W is the regressor of the base
    parameters ``parameters`` on the reference (q, q̇, q̈) sampled at ``rate_hz`` (the decimated rate);
    Nelder–Mead on the phases, at most ``maxfev`` evaluations. Returns (design, cond_before, cond_after)."""
    from scipy.optimize import minimize

    from tendyn.ident.model import cached_model
    from tendyn.ident.treatment import above_threshold

    model = cached_model(device)
    cols = np.array(model.base.columns)[[model.base.names.index(n) for n in parameters]]

    def cond_of(d):
        q, qd, qdd = d.references(duration, 1.0 / rate_hz)
        keep = above_threshold(qd, VELOCITY_THRESHOLD)          # IDIM's velocity threshold (the treatment's rule)
        W = model.regressor(q, qd, qdd)[:, cols]
        return float(np.linalg.cond(W[keep.T.ravel()]))

    c0 = cond_of(design)
    res = minimize(lambda p: cond_of(design.with_phases(p)), design.phases(), method="Nelder-Mead",
                   options={"maxfev": maxfev, "xatol": 1e-3, "fatol": 1e-3})
    best = design.with_phases(np.mod(res.x, 1.0))
    c1 = cond_of(best)
    return (best, c0, c1) if c1 < c0 else (design, c0, c0)


def calibrate_current_noise(device, design, duration: float, target_pct: float = 0.45, rows: int = PAPER_ROWS,
                            seed: int = 0) -> dict:
    """The current noise [A rms] that puts %σ(ZZ1R) of the Table 4 model at ``target_pct`` on a W of ``rows``
    rows (S2: 0.448 % on 15000 × 16).

    σ̂_ρ² = σ_m² + g σ_n²: the residual variance is the model/quantisation part plus the filtered noise, so
    %σ(ZZ1R)² (scaled to ``rows`` by σ ∝ 1/√r) is affine in σ_n². Two runs of the same trajectory — noise 0
    and the device's noise σ_a — give both coefficients; σ_n = σ_a √((p*² − p0²)/(p_a² − p0²)).
    """
    import re
    import tempfile
    from pathlib import Path

    from tendyn.device import compile_device, load_device
    from tendyn.ident import IDIM
    from tendyn.sim.experiments import exciting_trajectory

    dev = compile_device(device).device
    sigma_a = float(dev.drives[0].sensors.current_noise)
    text = Path(dev.path).read_text(encoding="utf-8")

    def pct(noise):
        with tempfile.TemporaryDirectory() as tmp:
            p = Path(tmp) / Path(dev.path).name
            p.write_text(re.sub(r"current_noise = [0-9.eE+-]+", f"current_noise = {noise!r}", text), encoding="utf-8")
            d = load_device(p)
            run = exciting_trajectory(d, duration=duration, design=design, seed=seed)
            est = IDIM(d, parameters=table4_names(), velocity_threshold=VELOCITY_THRESHOLD).fit(run.log, crossval=False)
        k = est.names_.index("ZZ1R")
        return float(est.rel_stderr_[k] * math.sqrt(est.result_.n_rows / rows))

    p0, pa = pct(0.0), pct(sigma_a)
    noise = sigma_a * math.sqrt(max(target_pct**2 - p0**2, 0.0) / max(pa**2 - p0**2, 1e-300))
    return {"noise_A": noise, "p0_pct": p0, "pa_pct": pa, "sigma_a_A": sigma_a, "target_pct": target_pct,
            "rows": rows}


def run_s2(device: Any, *, quick: bool = False, seed: int = 0, optimise: bool = True, progress=None) -> S2Report:
    """Run the S2 protocol on a capstan twin (default ``cea_branch``) and return the report.

    quick : shorter runs (tests): blocked tests of 2 cycles, 4 friction speeds, a 90 s exciting trajectory
        instead of the paper's length (320 s: W ≈ 15000 rows after the velocity threshold); %σ are also given scaled to 15000 rows.
    optimise : lower cond(W) by the phases of the exciting design (:func:`optimise_exciting`).
    """
    from tendyn.device import compile_device
    from tendyn.ident import IDIM
    from tendyn.sim.experiments import blocked_link, design_exciting, exciting_trajectory

    from .s2_friction import run_friction_protocol
    from .s2_stiffness import capstan_bandwidth, fit_capstan_stiffness, identification_band

    say = progress or (lambda msg: None)
    compiled = compile_device(device)
    dev = compiled.device
    if not dev.drives:
        raise ValueError(f"{dev.name}: pipeline s2 needs capstan [[drives]]")
    summary: dict = {"device": dev.name, "quick": bool(quick)}
    figures: dict = {}

    # ---- C31, C32: blocked links, K per drive, bandwidth, identification band ----------------------------
    stiff = []
    for i, d in enumerate(dev.drives, start=1):
        say(f"blocked-link test, drive of joint {d.joint}")
        run = blocked_link(compiled, i, torque_amplitude=0.1, period=2.0, cycles=2 if quick else 4,
                           rate_hz=5_000.0, seed=seed + i)
        fit = fit_capstan_stiffness(run.log, i, drive=d.joint)
        stiff.append(fit)
        figures[f"hysteresis_joint{d.joint}"] = fit
    summary["stiffness"] = [s.to_dict() for s in stiff]
    stiffness_motor = [s.K for s in stiff]
    summary["stiffness_motor_Nm_per_rad"] = stiffness_motor
    bw = capstan_bandwidth(compiled, stiffness_motor)
    band = identification_band(bw["bandwidth_hz"])
    summary["bandwidth_hz"] = bw["bandwidth_hz"]
    summary["bandwidth"] = bw
    summary["identification_band_hz"] = list(band)
    if dev.bandwidth_hz is not None:
        summary["device_bandwidth_hz"] = dev.bandwidth_hz   # what sets the treatment of IDIM

    # ---- C37: exciting trajectories inside the band, cond(W) ---------------------------------------------
    # S2's 16 Table 4 parameters when this device has them (the CEA branch and its variants); another arm (a
    # desktop arm with its own tree) is identified on all its base parameters, with no Table 4 comparison
    from tendyn.ident.estimate import cached_model

    base_names = cached_model(compiled).base.names
    paper_set = all(n in base_names for n in table4_names())
    params16 = table4_names() if paper_set else list(base_names)
    summary["parameters"] = "S2 Table 4" if paper_set else "every base parameter of the device"
    duration = 90.0 if quick else 320.0
    design = design_exciting(compiled, band_hz=band, seed=seed)
    summary["exciting_design"] = design.to_dict()
    if optimise:
        say("optimising the phases of the exciting trajectory for cond(W)")
        design, c0, c1 = optimise_exciting(compiled, design, params16, duration, maxfev=60 if quick else 150)
        summary["cond_design"] = {"before": c0, "after": c1}

    # ---- C33–C35: friction protocol (Table 3) ------------------------------------------------------------
    fp = run_friction_protocol(compiled, design.center, speeds=(0.15, 0.3, 0.5, 0.8) if quick else
                               (0.1, 0.2, 0.3, 0.45, 0.6, 0.8), seed=seed + 10, progress=say)
    summary["friction"] = fp.to_dict()
    from tendyn.devices import is_twin_of

    fp.paper = summary["paper_twin"] = is_twin_of(compiled, "cea_branch")   # compare with S2 only on S2's twin
    summary["friction_table"] = fp.table()
    summary["cond_friction"] = fp.to_dict()["cond"]
    figures["friction"] = fp

    # ---- C36, C38, C39: Table 4 ---------------------------------------------------------------------------
    say(f"exciting trajectory, {duration:g} s")
    run_fit = exciting_trajectory(compiled, duration=duration, design=design, seed=seed + 20)
    full = IDIM(compiled, velocity_threshold=VELOCITY_THRESHOLD).fit(run_fit.log, crossval=False)
    red = IDIM(compiled, parameters=params16, velocity_threshold=VELOCITY_THRESHOLD).fit(run_fit.log, crossval=False)
    summary["cond_exciting"] = red.cond_
    summary["cond_full"] = full.cond_
    summary["n_rows"] = red.result_.n_rows
    summary["residual_rel"] = red.result_.residual_rel
    summary["treatment"] = red.treatment_.to_dict()
    summary["velocity_threshold_rad_s"] = VELOCITY_THRESHOLD
    params = red.result_.to_dict()["params"]
    for p in params:
        p["paper_name"] = paper_name(p["name"])
    summary["params"] = params
    scale = math.sqrt(red.result_.n_rows / PAPER_ROWS)
    table4 = []
    for (pname, (pval, ppct)), ours in zip(TABLE4_PAPER.items() if paper_set else (), params16):
        k = red.names_.index(ours)
        x, s = float(red.params_[k]), float(red.stderr_[k])
        table4.append({"name": pname, "base_name": ours, "paper": pval, "identified": x, "stderr": s,
                       "rel_stderr_pct": float(red.rel_stderr_[k]),
                       "rel_stderr_pct_at_paper_rows": float(red.rel_stderr_[k] * scale),
                       "paper_rel_stderr_pct": ppct, "rel_error_pct": 100 * (x - pval) / abs(pval),
                       "within_3_sigma": bool(abs(x - pval) <= 3 * s)})
    summary["table4"] = table4
    summary["params_full"] = [dict(p, paper_name=paper_name(p["name"])) for p in full.result_.to_dict()["params"]]
    omitted = [p for p in summary["params_full"] if p["name"] not in params16]
    summary["omitted"] = [{"name": p["paper_name"], "base_name": p["name"], "value": p["value"],
                           "rel_stderr_pct": p["rel_stderr_pct"]} for p in omitted]
    pert = {}
    for n in params16:
        kf, kr = full.names_.index(n), red.names_.index(n)
        pert[n] = {"full": float(full.params_[kf]), "reduced": float(red.params_[kr]),
                   "shift_pct": float(100 * (red.params_[kr] - full.params_[kf]) / abs(full.params_[kf])),
                   "shift_sigma": float(abs(red.params_[kr] - full.params_[kf]) / full.stderr_[kf])}
    summary["omitted_perturbation"] = pert
    summary["omitted_perturbation_max_sigma"] = max((v["shift_sigma"] for v in pert.values()), default=0.0)
    figures["identification"] = red.result_

    # ---- C40: cross-validation on a trajectory not used for the fit ---------------------------------------
    say("cross-validation trajectory")
    val_design = design_exciting(compiled, band_hz=band, seed=seed + 1)
    run_val = exciting_trajectory(compiled, duration=40.0 if quick else 60.0, design=val_design, seed=seed + 30)
    Y, W, rows, t, na = red.observations(run_val.log)
    base = red._model().base
    y_hat = W[:, list(base.columns)][:, [base.names.index(n) for n in red.names_]] @ red.params_
    cv = CrossValidation(t, Y, y_hat, rows, list(red._model().active_numbers))
    summary["crossval"] = cv.to_dict()
    figures["crossval"] = cv

    # ---- C41–C46: operational maps and compensation from the identified values ----------------------------
    from tendyn.analysis.operational import operational_maps
    from tendyn.ident.calibrated import calibrate

    from .s2_compensation import compensation_from_identified

    say("operational maps from the identified Table 4 parameters and capstan stiffness")
    # the reduced model's document: its `omitted` parameters are zero on purpose (read_params refuses others missing)
    reduced = {"device": red.result_.device, "params": params, "omitted": red.result_.omitted}
    # the device with what S2 identified laid over it: the capstan stiffness per drive, the base parameters
    cal = calibrate(compiled, params=reduced, stiffness=stiffness_motor)
    maps = operational_maps(cal.compiled, cal.params, quick=quick, progress=say)
    summary["maps"] = maps.to_dict()
    summary["calibration_sources"] = {k: v for k, v in cal.sources.items() if k.startswith(("stiffness", "params"))}
    figures.update({f"maps_{name}": fig for name, fig in maps.figures.items()})
    # the controller gets the identified parameters; the twin it drives keeps the file's values (its stiffness)
    comp = compensation_from_identified(compiled, cal.params, quick=quick, progress=say)
    summary["compensation"] = comp.summary
    figures["compensation"] = comp

    return S2Report(summary, figures, stiffness_motor=stiffness_motor, params=params)
