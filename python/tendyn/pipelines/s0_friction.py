"""S0 friction identification on the L-EXOS twin: strategies S1 and S2 on every transmission (C7, C8).

For each transmission the twin runs constant-velocity moves (sim.experiments.constant_velocity) at
≥ 5 motor speeds per direction under S1 and under S2; :class:`tendyn.ident.TransmissionFriction` fits
C_m0 and ν from the logs alone; this pipeline — the one place that may read the twin's truth — computes
the true global values and compares.

True global values (S0 eqs. 18–19, corrected: ERRATA; bearings and reducers included). With no joint
torque and transmission i moving alone, the tension climbs from the driven pulley (0: a reducer passes
no loss without load) to the motor branch by branch; on a sliding branch (S0 eq. 11, corrected: ERRATA)
y = (x + a_b + ν_b Ṡ) / (1 − b_b) with a_b = τ_0 + bearing constants at the branch speed, b_b = β + bearing
load terms, Ṡ = k'_b q̇_m = r_m q̇_m (ERRATA eq. 16). Without β and bearings this is exactly
C_m0 = Σ τ_0,b |k'_b| and ν = Σ ν_b k'_b² (eqs. 18–19). C(q̇_m) = r_m y_0 is fitted by C_m0 sgn + ν q̇_m
over the speeds of the test (exact when the law is affine, i.e. without the h1 n^{2/3} bearing term).
An independent route (:func:`true_global_feedforward`) runs the core's statics with losses,
``Transmission.feedforward`` at zero joint torque; the tests check that both agree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from tendyn.protocols import DEFAULT_SPEEDS, LOOP_BANDWIDTH_HZ
from tendyn.ident.friction import FrictionFit, TransmissionFriction, residual_error_bound
from tendyn.results import Result
from tendyn.sim import experiments as ex


BANDWIDTH_HZ = LOOP_BANDWIDTH_HZ
"""Position-loop bandwidth of the tests [Hz] (:data:`tendyn.protocols.LOOP_BANDWIDTH_HZ`)."""


# ---- truth ---------------------------------------------------------------------------------------

def _branch_law(arr, i, b, sdot):
    """(a, b) of branch b of transmission i at branch speed sdot (as the core's branch_friction)."""
    a, bb = float(arr["tau0"][i, b]), float(arr["beta"][i, b])
    count = float(arr.get("bearing_count", np.zeros_like(arr["tau0"]))[i, b])
    if count > 0:
        r = float(arr["bearing_radius"][i, b])
        k = 2.0 * math.sin(0.5 * float(arr["bearing_wrap"][i, b]))
        n = abs(sdot / r)
        h = float(arr["bearing_h0"][i, b]) if n < float(arr["bearing_n0"][i, b]) \
            else float(arr["bearing_h1"][i, b]) * n ** (2.0 / 3.0)
        coef = float(arr["bearing_dynamic_coefficient"][i, b])
        a += count * (coef * k * float(arr["pretension"][i]) + h) / r
        bb += count * coef * k / r
    return a, bb


def true_motor_friction(arr, i: int, qd_motor: float) -> float:
    """True motor torque [N·m] that moves transmission i (0-based) alone at motor speed q̇_m > 0 with no
    joint torque, from the twin's routing/friction arrays (module docstring)."""
    r_m = float(arr["motor_radius"][i])
    sdot = r_m * qd_motor          # k'_b = r_m on every branch (ERRATA eq. 16)
    y = 0.0
    for b in range(i, -1, -1):
        a, bb = _branch_law(arr, i, b, sdot)
        y = (y + a + float(arr["nu"][i, b]) * sdot) / (1.0 - bb)
    return r_m * y


def _affine(speeds, torques):
    v = np.asarray(speeds, float)
    W = np.column_stack([np.ones_like(v), v])
    x, *_ = np.linalg.lstsq(W, np.asarray(torques, float), rcond=None)
    return float(x[0]), float(x[1])


def true_global_friction(arr, i: int, speeds=DEFAULT_SPEEDS) -> tuple[float, float]:
    """(C_m0 [N·m], ν [N·m·s/rad]) of transmission i (0-based): eqs. 18–19 with β, bearings, reducers."""
    return _affine(speeds, [true_motor_friction(arr, i, v) for v in speeds])


def true_global_feedforward(arr, i: int, speeds=DEFAULT_SPEEDS) -> tuple[float, float]:
    """The same from the core's statics with losses (independent route): the device file's equivalent friction
    of :func:`tendyn.analysis.handle_maps.equivalent_motor_friction` (``Transmission.feedforward(0, ±q̇)`` with only
    joint i moving at r_m q̇_m / r_i^i), transmission i (0-based)."""
    from tendyn.analysis.handle_maps import equivalent_motor_friction
    from tendyn.transmission import Transmission

    fields = [k for k in arr if k in ("tau0", "nu", "beta") or k.startswith("bearing_")]
    tr = Transmission.from_arrays(arr["motor_radius"], arr["K"], arr["reducer_ratio"], arr["reducer_efficiency"],
                                  arr["pretension"], **{k: arr[k] for k in fields if k in arr})
    coulomb, viscous = equivalent_motor_friction(tr, speeds)
    return float(coulomb[i]), float(viscous[i])


def _upstream(x, sdot, a, b, nu):
    """Motor-side tension of a sliding branch from its joint-side tension x (S0 eq. 11, corrected:
    ERRATA): y − s·b·max(|x|, |y|) = x + s·a + ν Ṡ, s = sgn Ṡ."""
    s = 1.0 if sdot > 0 else -1.0
    sb = s * b
    c = x + s * a + nu * sdot
    if c < -abs(x) * (1.0 + sb):
        return c / (1.0 + sb)
    if c <= abs(x) * (1.0 - sb):
        return c + sb * abs(x)
    return c / (1.0 - sb)


def motor_torques_with_losses(arr, torque_joint, qd) -> np.ndarray:
    """Motor torques [N·m] for joint torques τ_J [N·m] at joint speeds q̇ [rad/s] with every loss of the
    twin: joint equilibrium (S0 eq. 4), reducer efficiency (eqs. 9–10: ÷ η_d n driving, × η_i / n
    back-driven), the tension climbing each sliding branch (eq. 11 with τ_0, β, bearings, ν); a still
    branch passes its tension unchanged (static friction not compensated, S0 §III)."""
    K = arr["K"]
    n = K.shape[0]
    T = np.zeros((n, n))
    out = np.zeros(n)
    for i in range(n - 1, -1, -1):
        own = torque_joint[i] - sum(K[k, i] * T[k, i] for k in range(i + 1, n))
        ratio, eta = float(arr["reducer_ratio"][i]), float(arr["reducer_efficiency"][i])
        power = own * qd[i]
        pulley = own / ratio
        if power > 0:
            pulley = own / (eta * ratio)
        elif power < 0:
            pulley = 0.0 if eta <= 0.5 else (2 * eta - 1) / eta * own / ratio
        t = pulley / (K[i, i] / ratio)
        T[i, i] = t
        for b in range(i, -1, -1):
            sdot = float(np.dot(K[i, b:i + 1], qd[b:i + 1]))
            if sdot != 0.0:
                a, bb = _branch_law(arr, i, b, sdot)
                t = _upstream(t, sdot, a, bb, float(arr["nu"][i, b]))
            if b > 0:
                T[i, b - 1] = t
        out[i] = float(arr["motor_radius"][i]) * t
    return out


def true_global_at_load(arr, device, transmission: int, q0, travel_motor: float, speeds=DEFAULT_SPEEDS,
                        route: str = "python", points: int = 21) -> tuple[float, float]:
    """True (C_m0, ν) of transmission ``transmission`` (1-based) under the gravity load of the test:
    the isolated move (only its joint moving, from q0 over the middle 80 % of the stroke) at each speed
    forward and backward, motor torques with every loss (``route="python"``:
    :func:`motor_torques_with_losses`; ``"core"``: ``Transmission.feedforward``), gravity g(q) of the
    twin's rigid body; half the difference at the same position (S0's gravity removal), averaged, then
    fitted by C_m0 + ν|q̇_m|. The reducers' efficiency and β make the friction depend on the load, so this
    — not the zero-load value of eqs. 18–19 — is what a perfect test at that pose measures."""
    import pinocchio as pin

    from tendyn.device.rigid_body import pinocchio_model

    pm = pinocchio_model(device)
    pd = pm.createData()
    j = transmission - 1
    n = arr["K"].shape[0]
    per_motor = float(arr["motor_radius"][j] / arr["K"][j, j])
    if route == "core":
        from tendyn.transmission import Transmission

        fields = [k for k in arr if k in ("tau0", "nu", "beta") or k.startswith("bearing_")]
        tr = Transmission.from_arrays(arr["motor_radius"], arr["K"], arr["reducer_ratio"],
                                      arr["reducer_efficiency"], arr["pretension"], **{k: arr[k] for k in fields})
        torques = lambda g, qd: tr.feedforward(g, qd).torque_motor   # noqa: E731
    elif route == "python":
        torques = lambda g, qd: motor_torques_with_losses(arr, g, qd)   # noqa: E731
    else:
        raise ValueError(f"route must be 'python' or 'core' (got {route!r})")
    halves = []
    for v in speeds:
        d = []
        for s in np.linspace(0.1, 0.9, points) * travel_motor:
            q = np.array(q0, float).copy()
            q[j] += s * per_motor
            g = pin.computeGeneralizedGravity(pm, pd, q)
            qd = np.zeros(n)
            qd[j] = v * per_motor
            d.append(0.5 * (torques(g, qd)[j] - torques(g, -qd)[j]))
        halves.append(np.mean(d))
    return _affine(speeds, halves)


def truth_arrays(truth: dict) -> dict:
    """numpy arrays from a run's truth record (``SimRun.truth['routing']``)."""
    return {k: np.asarray(v, float) for k, v in truth["routing"].items()}


# ---- the comparison ------------------------------------------------------------------------------

@dataclass(eq=False)
class StrategyComparison(Result):
    """S1 vs S2 fits on every transmission against the twin's true global values (C8)."""

    device: str
    speeds_motor: list
    speeds_by_transmission: dict = field(default_factory=dict)   # transmission -> planned speeds [rad/s]
    truth: dict = field(default_factory=dict)       # transmission -> (C_m0, ν) at the test's load
    truth_zero_load: dict = field(default_factory=dict)  # transmission -> (C_m0, ν) of eqs. 18–19
    fits: dict = field(default_factory=dict)        # (transmission, strategy) -> FrictionFit
    bounds_truth: dict = field(default_factory=dict)  # (transmission, strategy) -> bound from the truth [N·m]

    @property
    def transmissions(self) -> list[int]:
        return sorted(self.truth)

    def torque_error(self, t: int, strategy: str) -> float:
        """RMS over the test speeds of |Ĉ(v) − C(v)| [N·m] at the test's load (the residual error C_m,err of
        S0 §III); Ĉ includes the identified load term at the test's mean load."""
        f = self.fits[(t, strategy)]
        c0, nu = self.truth[t]
        v = np.asarray(self.speeds_by_transmission.get(t, self.speeds_motor), float)
        return float(np.sqrt(np.mean(((f.coulomb_at_load() - c0) + (f.viscous_motor - nu) * v) ** 2)))

    def errors_pct(self, t: int, strategy: str) -> tuple[float, float]:
        """Errors [%] of the Coulomb part at the test's load and of ν against the truth at that load."""
        f = self.fits[(t, strategy)]
        c0, nu = self.truth[t]
        return 100 * (f.coulomb_at_load() - c0) / c0, 100 * (f.viscous_motor - nu) / nu

    def s2_better(self) -> dict:
        return {t: self.torque_error(t, "S2") < self.torque_error(t, "S1") for t in self.transmissions}

    def to_dict(self) -> dict:
        rows = []
        for t in self.transmissions:
            c0, nu = self.truth[t]
            z0, zn = self.truth_zero_load.get(t, (None, None))
            row = {"transmission": t, "true": {"coulomb_motor": c0, "viscous_motor": nu},
                   "true_zero_load": {"coulomb_motor": z0, "viscous_motor": zn}}
            for s in ("S1", "S2"):
                if (t, s) not in self.fits:
                    continue
                ec, ev = self.errors_pct(t, s)
                row[s] = dict(self.fits[(t, s)].to_dict(), coulomb_error_pct=ec, viscous_error_pct=ev,
                              torque_error_rms=self.torque_error(t, s),
                              residual_bound_truth=self.bounds_truth.get((t, s)))
            rows.append(row)
        return {"device": self.device, "speeds_motor": list(self.speeds_motor), "transmissions": rows}

    def table(self) -> str:
        h = (f"{'tr':<3}{'strat':<6}{'C_m0 [mN·m]':>12}{'true':>8}{'err %':>8}{'%σ':>7}"
             f"{'ν [mN·m·s]':>12}{'true':>8}{'err %':>8}{'%σ':>7}{'rms err':>10}{'bound':>9}")
        lines = [f"{self.device}: S0 friction identification, S1 vs S2 (C8); torques in mN·m, C_m0 at the test's "
                 "load (C_m0 + c_L |C_0|)", h]
        for t in self.transmissions:
            c0, nu = self.truth[t]
            for s in ("S1", "S2"):
                f = self.fits[(t, s)]
                ec, ev = self.errors_pct(t, s)
                rc, rv = f.rel_std_pct
                b = self.bounds_truth.get((t, s))
                lines.append(f"{t:<3}{s:<6}{1e3 * f.coulomb_at_load():>12.3f}{1e3 * c0:>8.3f}{ec:>8.1f}{rc:>7.2f}"
                             f"{1e3 * f.viscous_motor:>12.4f}{1e3 * nu:>8.4f}{ev:>8.1f}{rv:>7.2f}"
                             f"{1e3 * self.torque_error(t, s):>10.3f}{'' if b is None else f'{1e3 * b:.3f}':>9}")
        better = self.s2_better()
        lines.append("S2 smaller error: " + ", ".join(f"t{t} {'yes' if v else 'NO'}" for t, v in better.items()))
        return "\n".join(lines)

    reading = ('For each transmission, the rms error of the friction identified by strategy S1 and by S2 against the '
               "twin's truth (bars), with the 1σ of the fit (black ticks): the lower bar is the better strategy.")

    def _draw(self, ax) -> None:
        """RMS torque error of S1 and S2 per transmission (bars)."""
        ts = self.transmissions
        x = np.arange(len(ts))
        v = np.asarray(self.speeds_motor, float)
        for k, s in enumerate(("S1", "S2")):
            ax.bar(x + (k - 0.5) * 0.38, [1e3 * self.torque_error(t, s) for t in ts], 0.38, label=f"strategy {s}")
            # the part of the error noise explains: 1σ of the fitted law, rms over the speeds
            noise = [1e3 * float(np.sqrt(np.mean((self.fits[(t, s)].coulomb_motor_std
                                                  + self.fits[(t, s)].viscous_motor_std * v) ** 2))) for t in ts]
            ax.plot(x + (k - 0.5) * 0.38, noise, "k_", ms=14, mew=2, label="1σ of the fit" if k == 0 else None)
        ax.set_xticks(x, [f"t{t}" for t in ts])
        ax.set_ylabel("friction error at the motor, rms over speeds [mN·m]")
        ax.set_title(f"{self.device}: S1 vs S2 against the twin's truth")
        ax.legend()
        ax.grid(alpha=0.3, axis="y")


def stroke_plan(device, transmission: int, travel_motor: float | None = None, speeds=None):
    """(q0 [rad], motor travel [rad], speeds [rad/s]) of the test of ``transmission`` (1-based): the first pose,
    stroke and speeds of the planned test (:func:`tendyn.protocols.plan_test`: the stroke centred in the driven
    joint's range, the other joints mid-range, at most ``travel_motor``; default speeds scaled down where the
    stroke is short)."""
    from tendyn.protocols import plan_test

    test = plan_test(device, transmission, "S2", speeds, travel=travel_motor, loads=1, strict=False)
    return test.poses[0], test.travel, test.speeds


def compare_strategies(device, transmissions=None, speeds=None, travel_motor: float | None = None,
                       seed: int = 0, gravity: str = "pairs", rate_hz: float = 10_000.0,
                       bandwidth_hz: float = BANDWIDTH_HZ, progress=None, keep_runs: bool = False):
    """Run S1 and S2 on each transmission, fit, compare with the truth. Returns a
    :class:`StrategyComparison` (and the runs when ``keep_runs``)."""
    transmissions = list(range(1, device.n_transmissions + 1)) if transmissions is None else list(transmissions)
    out = StrategyComparison(device.name, [float(v) for v in (DEFAULT_SPEEDS if speeds is None else speeds)])
    runs = {}
    for t in transmissions:
        q0, travel, sp = stroke_plan(device, t, travel_motor, speeds)
        out.speeds_by_transmission[t] = list(sp)
        for s in ("S1", "S2"):
            run = ex.constant_velocity(device, t, sp, strategy=s, travel=travel, q0=q0, seed=seed,
                                       rate_hz=rate_hz, bandwidth_hz=bandwidth_hz)
            est = TransmissionFriction(t, gravity=gravity, device=device if gravity != "pairs" else None)
            fit: FrictionFit = est.fit([run.log]).result_
            out.fits[(t, s)] = fit
            arr = truth_arrays(run.truth)
            out.truth[t] = true_global_at_load(arr, device, t, q0, travel, sp)
            out.truth_zero_load[t] = true_global_friction(arr, t - 1, sp)
            out.bounds_truth[(t, s)] = residual_error_bound(arr["K"], arr["motor_radius"], t - 1, s,
                                                            arr["tau0"], arr["nu"], max(sp))
            if keep_runs:
                runs[(t, s)] = run
            if progress:
                progress(t, s)
    return (out, runs) if keep_runs else out


def run_s0_friction(out_dir, device=None, seed: int = 0, progress=None) -> StrategyComparison:
    """The full C7–C9 pipeline on the L-EXOS twin: S1 and S2 on every transmission (default speeds,
    longest strokes inside the limits), the comparison table (``s0_friction.txt``), its figure
    (``s0_friction.png``: rms error per transmission and strategy), the JSON (``s0_friction.json``), the
    S2 FRICTION.json (``friction_S2.json``) and its decomposition with the default shares
    (``decomposition_S2.json``, with the check of eqs. 18–19). Returns the comparison."""
    import json
    from pathlib import Path

    from matplotlib.figure import Figure

    from tendyn.device import load_device
    from tendyn.devices import bundled
    from tendyn.ident.decomposition import decompose
    from tendyn.ident.friction_file import friction_document, write_friction
    from tendyn.io import atomic_write_text, save_png, to_jsonable

    device = load_device(bundled("lexos")) if device is None else device
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    cmp = compare_strategies(device, seed=seed, progress=progress)
    fig = Figure(figsize=(11.2, 4.2))
    ax1, ax2 = fig.subplots(1, 2)
    cmp.plot(ax1)
    for s, marker in (("S1", "o"), ("S2", "s")):
        ts = cmp.transmissions
        ax2.plot(ts, [cmp.errors_pct(t, s)[0] for t in ts], marker + "-", label=f"{s}: C_m0")
        ax2.plot(ts, [cmp.errors_pct(t, s)[1] for t in ts], marker + "--", label=f"{s}: ν")
    ax2.axhline(0, color="0.6", lw=0.8)
    ax2.set_xticks(cmp.transmissions)
    ax2.set_xlabel("transmission")
    ax2.set_ylabel("error against the twin's truth [%]")
    ax2.legend(fontsize=8)
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    save_png(fig, out / "s0_friction.png")
    atomic_write_text(out / "s0_friction.txt", cmp.table() + "\n")
    atomic_write_text(out / "s0_friction.json", json.dumps(to_jsonable(cmp.to_dict()), indent=2) + "\n")
    fits = [cmp.fits[(t, "S2")] for t in cmp.transmissions]
    write_friction(friction_document(device.name, fits), out / "friction_S2.json")
    dec = decompose(device, [f.coulomb_motor for f in fits], [f.viscous_motor for f in fits])
    atomic_write_text(out / "decomposition_S2.json", json.dumps(to_jsonable(dec.to_dict()), indent=2) + "\n")
    return cmp


if __name__ == "__main__":   # python -m tendyn.pipelines.s0_friction OUT_DIR
    import sys

    result = run_s0_friction(sys.argv[1] if len(sys.argv) > 1 else "out/s0_friction",
                             progress=lambda t, s: print(f"transmission {t} {s} done", file=sys.stderr))
    print(result.table())
