"""The design space of a device file and its objectives, evaluated for many designs at once (issue 32).

A *design* is a vector of the device file's design values (``--vary NAME=LO:HI``) and, optionally, the index of a
motor in a table the user gives. :class:`DesignSpace` is built once per device (it reduces what does not depend on
the design — kinematics, link inertia, the loss model — through the core) and then evaluates a batch of designs
X (D, V) in numpy over the designs: no Python loop per design (:meth:`DesignSpace.evaluate`).

Serial cable devices (``[[transmissions]]``, L-EXOS); design values ``<transmission>.<field>`` with field one of
:data:`SERIAL_FIELDS`. Per design, with G = R_m⁻¹ K the motor-from-joint matrix (S0 eqs. 1–2, corrected: ERRATA;
K_ii = driven_radius · reducer_ratio, S0 footnote 1) and, at each pose of a fixed grid of the joint workspace
(the grid of :mod:`tendyn.analysis.handle_maps`, poses with cond(J_r) ≤ ``MAX_CONDITION``):

* A = M_links(q) + Gᵀ diag(I_r) G, Λ = (J_r A⁻¹ J_rᵀ)⁻¹ — ``apparent_mass`` [kg] = workspace mean of λ_max(Λ);
* B_J = Gᵀ diag(ν) G, B = (J_r B_J⁻¹ J_rᵀ)⁻¹ — ``viscous_friction`` [N·s/m] = workspace mean of λ_max(B);
* ``dry_friction`` [N]: pushing the handle from rest along a basis direction u the joints follow
  q̇ = A⁻¹ J_rᵀ Λ u (the Gauss minimum: Ẍ = Λ⁻¹ F), and the operator supplies Σ_i C_m0,i |(G q̇)_i| per m/s
  (virtual work); mean over the directions and the poses;
* ``peak_force`` / ``continuous_force`` [N]: the radius of the largest ball of handle forces the motors hold at
  their peak / continuous torque, min_i τ_i / ‖row_i(G⁻ᵀ J_rᵀ)‖ (statics τ = Gᵀ y, lossless, gravity apart), at
  the worst pose;
* ``zwidth`` [N/m]: the passive wall stiffness of Colgate & Schenkel at B = 0, K < 2 b / T, with b the least
  viscous friction at the handle (λ_min(B), worst pose) and T = 1 / ``rate_hz``;
* ``slack_margin`` [N]: min over transmissions of 2 T_0 − τ_peak / r_m (a closed cable at pretension T_0 slackens
  when the tension difference the motor asks exceeds 2 T_0).

The motor friction (C_m0, ν) per transmission comes from the core's statics of the shipped file
(:func:`tendyn.analysis.handle_maps.equivalent_motor_friction`, S0 eqs. 18–19 at zero load) and scales with the
design as C_m0 = r_m a_i, ν = r_m² b_i (the drop along the cable is a force, the cable speed r_m q̇_m; the
pretension and the reducer do not enter at zero load — the core gives the same a_i, b_i for every pretension,
driven radius, reducer ratio and efficiency; a test checks this against the core on written device files).
Schema 1 gives a cable device no cable stiffness: ``stiffness``, ``resonance_hz``, ``bandwidth_hz``,
``sensitivity_k1`` are refused there.

Tendon benches (``tendon_bench_2n``, McGill, S1); design values the ``[bench]`` fields of :data:`BENCH_VARY`.
The plant is S1's two-mass chain (ERRATA S1; :mod:`tendyn.analysis.tendon_drive`), m1 = r² I_M, c1 = r² B:
varying ``ratio`` keeps the motor-side I_M = mass_motor / r₀² and B = damping_motor / r₀² of the file (or the
chosen motor's). G(jω) = k_e Q / (P (Q + k_e) + k_e Q), P = m1 s² + c1 s, Q = I_c s² + k_z.

* ``dry_friction`` [N] = 2 (F_c0 + μ_T T_pre) (two motor/tendon nodes); ``viscous_friction`` [N·s/m] = c1;
  ``apparent_mass`` [kg] = m1 + I_c (stiff tendons); ``stiffness`` [N/m] = k_e (S1 eq. 1);
* ``resonance_hz`` [Hz]: the first undamped natural frequency of the chain (smaller root of
  m1 I_c ω⁴ − (m1 (k_e + k_z) + I_c k_e) ω² + k_e k_z = 0);
* ``bandwidth_hz`` [Hz]: the highest frequency of a log grid (0.01–1000 Hz, 600 points) with |G| ≥ |G(0)|/√2
  (as :class:`tendyn.analysis.s1_plant.SensitivityStudy`); ``sensitivity_k1`` [-]: max over that grid of
  |S_k1^G| (:func:`tendyn.analysis.s1_plant.sensitivity`), C16;
* ``rejection`` [-]: the effort |F_τ| = 1/|G(jω_b)| per newton of output at the band edge ``band_hz`` over the
  dry friction (C15's "rejection of friction relative to effort"; S1 eq. 3 is not used, ERRATA);
* ``peak_force`` / ``continuous_force`` [N] = r τ |G(0)|; ``band_force`` [N] = r τ_peak min_{ω ≤ ω_b} |G(jω)|,
  the output amplitude the motor delivers over the whole band before it saturates (C15);
* ``zwidth`` [N/m] = 2 c1 ``rate_hz`` (Colgate's passive bound at the rim).

Motor tables (CSV, header ``name,rotor_inertia,continuous_torque,peak_torque[,torque_constant][,damping]``): for a
serial device kg·m², N·m, N·m, N·m/A; for a bench the motor-side values of the chain at unit ratio, I_M [kg],
force limits [N], B [N·s/m] (optional: the file's B otherwise).
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np

__all__ = ["QUANTITIES", "SERIAL_FIELDS", "BENCH_VARY", "DesignSpace", "read_motor_table", "parse_vary",
           "parse_constraint", "device_text"]

# name -> (unit, sense, kinds, description); sense "min" or "max" is what is better
QUANTITIES: dict[str, tuple[str, str, tuple[str, ...], str]] = {
    "dry_friction": ("N", "min", ("serial", "bench"), "dry friction felt at the handle"),
    "viscous_friction": ("N·s/m", "min", ("serial", "bench"), "viscous friction at the handle"),
    "apparent_mass": ("kg", "min", ("serial", "bench"), "apparent mass at the handle"),
    "stiffness": ("N/m", "max", ("bench",), "transmission stiffness k_e"),
    "resonance_hz": ("Hz", "max", ("bench",), "first resonance of the drive (S1 plant)"),
    "bandwidth_hz": ("Hz", "max", ("bench",), "-3 dB bandwidth of F_m/F_τ"),
    "sensitivity_k1": ("-", "min", ("bench",), "peak |S_k1| (C16)"),
    "rejection": ("-", "max", ("bench",), "effort over friction at the band edge (C15)"),
    "zwidth": ("N/m", "max", ("serial", "bench"), "passive wall stiffness 2b/T (Colgate)"),
    "peak_force": ("N", "max", ("serial", "bench"), "force at peak torque"),
    "continuous_force": ("N", "max", ("serial", "bench"), "force at continuous torque"),
    "band_force": ("N", "max", ("bench",), "force over the whole band at peak torque (saturation, C15)"),
    "slack_margin": ("N", "max", ("serial",), "2 T_0 - peak cable tension difference"),
}
"""The fixed vocabulary of ``--objective`` and ``--constraint``."""

NEEDS_TORQUE = ("peak_force", "continuous_force", "band_force", "slack_margin")
SERIAL_FIELDS = {"motor_radius": "m", "driven_radius": "m", "reducer_ratio": "-", "pretension": "N"}
"""Design values of each ``[[transmissions]]`` entry (``--vary t2.reducer_ratio=4:12``)."""
BENCH_VARY = ("ratio", "k1", "k2", "pretension", "mass_motor", "damping_motor", "mass_load", "k_z", "friction_c0",
              "friction_mu_tension")
"""``[bench]`` fields a bench design may vary."""
MOTOR = "motor"
"""Name of the motor-choice variable (an index into the motor table)."""

FREQ_HZ = np.logspace(-2, 3, 600)
"""The frequency grid of ``bandwidth_hz`` and ``sensitivity_k1`` [Hz] (as S1's sensitivity study)."""
BAND_POINTS = 200


def parse_vary(text: str) -> tuple[str, float, float]:
    """``NAME=LO:HI`` → (name, lo, hi); ValueError with the reason (finite, LO < HI)."""
    m = re.fullmatch(r"\s*([A-Za-z0-9_.]+)\s*=\s*([^:]+):([^:]+)\s*", text)
    if not m:
        raise ValueError(f"expected NAME=LO:HI (got {text!r})")
    try:
        lo, hi = float(m.group(2)), float(m.group(3))
    except ValueError:
        raise ValueError(f"LO and HI must be numbers (got {text!r})") from None
    if not (math.isfinite(lo) and math.isfinite(hi)) or not lo < hi:
        raise ValueError(f"need finite LO < HI (got {text!r})")
    return m.group(1), lo, hi


def parse_constraint(text: str) -> tuple[str, str, float]:
    """``NAME>=X`` or ``NAME<=X`` → (name, op, bound); ValueError with the reason."""
    m = re.fullmatch(r"\s*([A-Za-z0-9_]+)\s*(>=|<=)\s*(\S+)\s*", text)
    if not m:
        raise ValueError(f"expected NAME>=X or NAME<=X (got {text!r})")
    if m.group(1) not in QUANTITIES:
        raise ValueError(f"unknown quantity {m.group(1)!r} (known: {', '.join(QUANTITIES)})")
    try:
        x = float(m.group(3))
    except ValueError:
        raise ValueError(f"bound must be a number (got {m.group(3)!r})") from None
    if not math.isfinite(x):
        raise ValueError(f"bound must be finite (got {m.group(3)!r})")
    return m.group(1), m.group(2), x


def read_motor_table(path) -> list[dict]:
    """Rows of a motor table (module docstring); ValueError naming the row and column."""
    need = ("name", "rotor_inertia", "continuous_torque", "peak_torque")
    rows = []
    with open(path, newline="", encoding="utf-8") as fh:
        reader = csv.DictReader(fh)
        missing = [c for c in need if c not in (reader.fieldnames or [])]
        if missing:
            raise ValueError(f"{path}: missing column(s) {', '.join(missing)} (need {', '.join(need)})")
        for k, row in enumerate(reader, start=2):
            out = {"name": row["name"].strip()}
            for col in ("rotor_inertia", "continuous_torque", "peak_torque", "torque_constant", "damping"):
                if col not in row or row[col] in (None, ""):
                    continue
                try:
                    v = float(row[col])
                except ValueError:
                    raise ValueError(f"{path}: line {k}: {col} must be a number (got {row[col]!r})") from None
                if not math.isfinite(v) or v < 0 or (v == 0 and col != "damping"):
                    raise ValueError(f"{path}: line {k}: {col} must be finite and > 0 (got {row[col]!r})")
                out[col] = v
            if out["continuous_torque"] > out["peak_torque"]:
                raise ValueError(f"{path}: line {k}: continuous_torque > peak_torque")
            rows.append(out)
    if not rows:
        raise ValueError(f"{path}: no motors")
    return rows


def sym_extremes(S) -> tuple[np.ndarray, np.ndarray]:
    """(λ_min, λ_max) of stacked symmetric matrices S (..., r, r): closed forms for r ≤ 3 (r = 3: the
    trigonometric solution of the characteristic cubic), ``numpy.linalg.eigvalsh`` otherwise."""
    r = S.shape[-1]
    if r == 1:
        return S[..., 0, 0], S[..., 0, 0]
    if r == 2:
        m = 0.5 * (S[..., 0, 0] + S[..., 1, 1])
        h = np.hypot(0.5 * (S[..., 0, 0] - S[..., 1, 1]), S[..., 0, 1])
        return m - h, m + h
    if r != 3:
        ev = np.linalg.eigvalsh(S)
        return ev[..., 0], ev[..., -1]
    a, b, c = S[..., 0, 0], S[..., 1, 1], S[..., 2, 2]
    d, e, f = S[..., 0, 1], S[..., 0, 2], S[..., 1, 2]
    q = (a + b + c) / 3.0
    p1 = d * d + e * e + f * f
    p = np.sqrt(((a - q) ** 2 + (b - q) ** 2 + (c - q) ** 2 + 2.0 * p1) / 6.0)
    ps = np.where(p > 0, p, 1.0)
    A, B, C = (a - q) / ps, (b - q) / ps, (c - q) / ps
    D, E, F = d / ps, e / ps, f / ps
    half_det = 0.5 * (A * (B * C - F * F) - D * (D * C - F * E) + E * (D * F - B * E))
    phi = np.arccos(np.clip(half_det, -1.0, 1.0)) / 3.0
    hi = q + 2.0 * p * np.cos(phi)
    lo = q + 2.0 * p * np.cos(phi + 2.0 * math.pi / 3.0)
    return lo, hi


@dataclass
class _Serial:
    names: list            # transmission names
    Q: np.ndarray          # (P, n) poses [rad]
    M: np.ndarray          # (P, n, n) link inertia, active coordinates [kg m²]
    Jr: np.ndarray         # (P, r, n) [m/rad]
    K0: np.ndarray         # (n, n) shipped K [m]
    fields: dict           # field -> (n,) shipped values
    a: np.ndarray          # (n,) C_m0 / r_m [N]
    b: np.ndarray          # (n,) ν / r_m² [N·s/m]
    motor: dict            # rotor_inertia, continuous_torque, peak_torque, torque_constant -> (n,)


class DesignSpace:
    """The design values of ``device`` that vary (``vary``: name → (lo, hi)) and, with ``motors``, the motor index.

    Parameters
    ----------
    device : device file path, bundled name, Device or CompiledDevice
    vary : {name: (lo, hi)} — bench fields (:data:`BENCH_VARY`) or ``<transmission>.<field>`` (:data:`SERIAL_FIELDS`)
    motors : rows of :func:`read_motor_table` or None
    rate_hz : control rate of the rendered wall [Hz] (``zwidth``)
    band_hz : band edge [Hz] of ``rejection`` and ``band_force``
    pose_budget : poses of the workspace grid (serial devices)

    Raises KeyError naming an unknown design value; ValueError for a device kind without a design space.
    The object holds numpy arrays and text only: it pickles small and ships once to Dask workers.
    """

    def __init__(self, device, vary: dict, motors: Sequence[dict] | None = None, *, rate_hz: float = 1000.0,
                 band_hz: float = 40.0, pose_budget: int = 200):
        from tendyn.device import compile_device

        if isinstance(device, (str, Path)):
            from tendyn.devices import load

            device = load(device)
        compiled = compile_device(device)
        dev = compiled.device
        self.device_name = dev.name
        path = getattr(dev, "path", None)
        self.text = Path(path).read_text(encoding="utf-8") if path else None
        self.rate_hz, self.band_hz = float(rate_hz), float(band_hz)
        self.motors = [dict(m) for m in motors] if motors else None
        self.vary = {k: (float(lo), float(hi)) for k, (lo, hi) in vary.items()}
        if dev.kind == "tendon_bench_2n":
            self.kind = "bench"
            self.bench = {k: float(v) for k, v in dev.to_dict().items() if k in BENCH_VARY}
            for k in self.vary:
                if k not in BENCH_VARY:
                    raise KeyError(f"{k!r} is not a design value of {dev.name} (known: {', '.join(BENCH_VARY)})")
        elif dev.kind == "serial" and dev.transmissions:
            self.kind = "serial"
            self.serial = self._serial(compiled, pose_budget)
            known = [f"{t}.{f}" for t in self.serial.names for f in SERIAL_FIELDS]
            for k in self.vary:
                if k not in known:
                    raise KeyError(f"{k!r} is not a design value of {dev.name} (known: {', '.join(known)})")
        else:
            raise ValueError(f"{dev.name}: a design space needs a tendon bench or a serial device with "
                             f"[[transmissions]] (got kind {dev.kind!r})")
        self.names = list(self.vary) + ([MOTOR] if self.motors else [])
        self.lower = np.array([lo for lo, _ in self.vary.values()] + ([0.0] if self.motors else []))
        self.upper = np.array([hi for _, hi in self.vary.values()]
                              + ([len(self.motors) - 1e-9] if self.motors else []))

    # ---- setup --------------------------------------------------------------------------------------------
    @staticmethod
    def _serial(compiled, budget) -> _Serial:
        from tendyn.analysis.handle_maps import (MAX_CONDITION, RANK_TOL, equivalent_motor_friction, joint_grid)
        from tendyn.analysis.handle_point import HandlePoint
        from tendyn.device.closed_loop import active_mass_matrix

        dev = compiled.device
        handle = HandlePoint(compiled)
        Q, _ = joint_grid(handle, budget=budget)
        Js = np.array([handle.jacobian(q) for q in Q])
        U, s, _ = np.linalg.svd(Js)
        ranks = np.sum(s > RANK_TOL * s[:, :1], axis=1)
        r = int(ranks.max())
        cond = s[:, 0] / s[:, r - 1]
        keep = (ranks == r) & (cond <= MAX_CONDITION)
        Q, Js, U = Q[keep], Js[keep], U[keep]
        Jr = np.einsum("pkr,pkn->prn", U[:, :, :r], Js)
        pd = compiled.pinocchio_data()
        M = np.array([active_mass_matrix(compiled.pinocchio_model, handle.L, handle.c, q, pd) for q in Q])
        mats = compiled.transmission.matrices()
        r_m = np.diag(mats["R_m"])
        C, nu = equivalent_motor_friction(compiled.transmission)
        ts = dev.transmissions
        fields = {f: np.array([getattr(t, f) for t in ts], float) for f in SERIAL_FIELDS}
        motor = {k: np.array([getattr(t.motor, k) for t in ts], float)
                 for k in ("rotor_inertia", "continuous_torque", "peak_torque", "torque_constant")}
        return _Serial([t.name for t in ts], Q, M, Jr, np.array(mats["K"], float), fields, C / r_m, nu / r_m**2,
                       motor)

    # ---- designs --------------------------------------------------------------------------------------------
    @property
    def shipped(self) -> np.ndarray:
        """The design of the file itself (V,); the motor index is −1 (the file's own motor)."""
        x = []
        for k in self.vary:
            if self.kind == "bench":
                x.append(self.bench[k])
            else:
                t, f = k.split(".")
                x.append(self.serial.fields[f][self.serial.names.index(t)])
        return np.array(x + ([-1.0] if self.motors else []))

    def motor_index(self, X) -> np.ndarray:
        """(D,) motor row per design (−1: the file's motor)."""
        if not self.motors:
            return np.full(len(X), -1, int)
        return np.floor(np.asarray(X, float)[:, -1]).astype(int)

    def values(self, x) -> dict:
        """The design values of one design {name: value} (the motor as its name)."""
        out = {k: float(v) for k, v in zip(self.vary, x)}
        if self.motors:
            i = int(math.floor(x[-1]))
            out[MOTOR] = "file" if i < 0 else self.motors[i]["name"]
        return out

    def available(self) -> list[str]:
        """Quantities this device and motor data can evaluate."""
        out = []
        for q, (_, _, kinds, _) in QUANTITIES.items():
            if self.kind not in kinds:
                continue
            if q in NEEDS_TORQUE and self.kind == "bench" and not self.motors:
                continue
            out.append(q)
        return out

    def why_not(self, q: str) -> str:
        """Why quantity ``q`` is not available here (one sentence), or ''."""
        if q not in QUANTITIES:
            return f"unknown quantity {q!r} (known: {', '.join(QUANTITIES)})"
        if q in self.available():
            return ""
        if self.kind not in QUANTITIES[q][2]:
            if self.kind == "serial":
                return (f"{q} needs a cable stiffness, which a [[transmissions]] device file does not give "
                        f"(schema 1); available: {', '.join(self.available())}")
            return f"{q} is a quantity of serial devices; available: {', '.join(self.available())}"
        return f"{q} needs motor torque limits: give --motors TABLE (a bench file has none)"

    # ---- evaluation -----------------------------------------------------------------------------------------
    def evaluate(self, X, which: Sequence[str] | None = None) -> dict[str, np.ndarray]:
        """Every available quantity (or ``which``) of the designs X (D, V) as arrays (D,), in numpy over D."""
        X = np.atleast_2d(np.asarray(X, float))
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):   # a degenerate design gives NaN/inf
            out = self._bench(X) if self.kind == "bench" else self._serial_eval(X)
        return out if which is None else {k: out[k] for k in which}

    def _column(self, X, name, default):
        if name in self.vary:
            return X[:, list(self.vary).index(name)]
        return np.broadcast_to(np.asarray(default, float), (len(X),) + np.shape(default)).copy()

    def _motor_values(self, X, key, file_value, scale=1.0):
        """(D,) or (D, n): the chosen motor's ``key`` (× scale), the file's where the index is −1."""
        idx = self.motor_index(X)
        base = np.broadcast_to(np.asarray(file_value, float), (len(X),) + np.shape(file_value)).copy()
        if self.motors:
            table = np.array([m.get(key, np.nan) * scale for m in self.motors], float)
            sel = idx >= 0
            vals = table[np.clip(idx, 0, None)]
            ok = sel & np.isfinite(vals)
            base[ok] = vals[ok][:, None] if base.ndim == 2 else vals[ok]
        return base

    def _bench(self, X) -> dict:
        b = self.bench
        r0 = b["ratio"]
        r = self._column(X, "ratio", r0)
        I_M = self._motor_values(X, "rotor_inertia", b["mass_motor"] / r0**2)
        B = self._motor_values(X, "damping", b["damping_motor"] / r0**2)
        m1 = X[:, list(self.vary).index("mass_motor")] if "mass_motor" in self.vary else r**2 * I_M
        c1 = X[:, list(self.vary).index("damping_motor")] if "damping_motor" in self.vary else r**2 * B
        k1, k2 = self._column(X, "k1", b["k1"]), self._column(X, "k2", b["k2"])
        Ic, kz = self._column(X, "mass_load", b["mass_load"]), self._column(X, "k_z", b["k_z"])
        T0 = self._column(X, "pretension", b["pretension"])
        c0, mu = self._column(X, "friction_c0", b["friction_c0"]), self._column(X, "friction_mu_tension",
                                                                               b["friction_mu_tension"])
        ke = k1 * k2 / (k1 + k2)
        dry = 2.0 * (c0 + mu * T0)
        a = m1 * Ic
        bb = m1 * (ke + kz) + Ic * ke
        c = ke * kz
        disc = np.sqrt(np.maximum(bb**2 - 4 * a * c, 0.0))
        w2 = np.where(c > 0, 2 * c / (bb + disc), bb / a)
        out = {"dry_friction": dry, "viscous_friction": c1, "apparent_mass": m1 + Ic, "stiffness": ke,
               "resonance_hz": np.sqrt(w2) / (2 * math.pi), "zwidth": 2.0 * c1 * self.rate_hz}

        def G(omega):                       # (D, F) from (F,)
            s = 1j * omega[None, :]
            P = m1[:, None] * s**2 + c1[:, None] * s
            Qs = Ic[:, None] * s**2 + kz[:, None]
            k = ke[:, None]
            return k * Qs / (P * (Qs + k) + k * Qs)

        g = np.abs(G(2 * math.pi * FREQ_HZ))
        ok = g >= g[:, :1] / math.sqrt(2)
        last = FREQ_HZ.size - 1 - np.argmax(ok[:, ::-1], axis=1)
        out["bandwidth_hz"] = FREQ_HZ[last]
        S = self._sens_k1(m1, c1, k1, k2, Ic, kz)
        out["sensitivity_k1"] = np.max(np.abs(S), axis=1)
        band = G(2 * math.pi * np.linspace(0.0, self.band_hz, BAND_POINTS))
        out["rejection"] = 1.0 / np.abs(band[:, -1]) / dry
        if self.motors:
            peak = self._motor_values(X, "peak_torque", np.nan)
            cont = self._motor_values(X, "continuous_torque", np.nan)
            g0 = np.abs(band[:, 0])
            out["peak_force"] = r * peak * g0
            out["continuous_force"] = r * cont * g0
            out["band_force"] = r * peak * np.min(np.abs(band), axis=1)
        return out

    @staticmethod
    def _sens_k1(m1, c1, k1, k2, Ic, kz):
        """S_k1^G on :data:`FREQ_HZ` (D, F) by :func:`tendyn.analysis.s1_plant.sensitivity` (r = 1: rim values)."""
        from tendyn.analysis.s1_plant import PlantParams, sensitivity

        col = (lambda v: np.asarray(v, float))
        return sensitivity(PlantParams(), omega=2 * math.pi * FREQ_HZ, which=("k1",), r=np.ones_like(col(m1)),
                           I_M=col(m1), B=col(c1), k1=col(k1), k2=col(k2), I_c=col(Ic), k_z=col(kz))["k1"]

    def _serial_eval(self, X) -> dict:
        s = self.serial
        D, n = len(X), len(s.names)

        def field(f):
            out = np.broadcast_to(s.fields[f], (D, n)).copy()
            for i, t in enumerate(s.names):
                k = f"{t}.{f}"
                if k in self.vary:
                    out[:, i] = X[:, list(self.vary).index(k)]
            return out

        r_m, dr, red, T0 = field("motor_radius"), field("driven_radius"), field("reducer_ratio"), field("pretension")
        I_r = self._motor_values(X, "rotor_inertia", s.motor["rotor_inertia"])
        peak = self._motor_values(X, "peak_torque", s.motor["peak_torque"])
        cont = self._motor_values(X, "continuous_torque", s.motor["continuous_torque"])
        K = np.broadcast_to(s.K0, (D, n, n)).copy()
        K[:, np.arange(n), np.arange(n)] = dr * red
        G = K / r_m[:, :, None]                                   # (D, n, n): q̇_m = G q̇
        Ginv = np.linalg.inv(G)
        C = s.a * r_m                                             # (D, n) [N·m]
        nu = s.b * r_m**2                                         # (D, n) [N·m·s/rad]
        rot = np.einsum("dki,dk,dkj->dij", G, I_r, G)             # Gᵀ diag(I_r) G
        A = s.M[None] + rot[:, None]                              # (D, P, n, n)
        JrT = np.swapaxes(s.Jr, -1, -2)[None]                     # (1, P, n, r)
        Xs = np.linalg.solve(A, np.broadcast_to(JrT, A.shape[:2] + JrT.shape[2:]))   # A⁻¹ J_rᵀ
        Lam = np.linalg.inv(s.Jr[None] @ Xs)                      # (D, P, r, r)
        Lam = 0.5 * (Lam + np.swapaxes(Lam, -1, -2))
        BJinv = np.einsum("dik,dk,djk->dij", Ginv, 1.0 / nu, Ginv)  # G⁻¹ diag(1/ν) G⁻ᵀ
        Bh = np.linalg.inv(s.Jr[None] @ BJinv[:, None] @ JrT)
        Bh = 0.5 * (Bh + np.swapaxes(Bh, -1, -2))
        qd = Xs @ Lam                                             # (D, P, n, r): columns q̇ per direction
        motor_speed = G[:, None] @ qd                             # (D, P, n, r)
        dry = np.einsum("dk,dpkr->dpr", C, np.abs(motor_speed))
        rows = np.swapaxes(Ginv, -1, -2)[:, None] @ JrT           # (D, P, n, r) = G⁻ᵀ J_rᵀ
        norms = np.linalg.norm(rows, axis=-1)                     # (D, P, n)
        b_lo, b_hi = sym_extremes(Bh)
        return {"dry_friction": dry.mean(axis=(1, 2)), "viscous_friction": b_hi.mean(axis=1),
                "apparent_mass": sym_extremes(Lam)[1].mean(axis=1),
                "zwidth": 2.0 * self.rate_hz * b_lo.min(axis=1),
                "peak_force": np.min(peak[:, None] / norms, axis=(1, 2)),
                "continuous_force": np.min(cont[:, None] / norms, axis=(1, 2)),
                "slack_margin": np.min(2.0 * T0 - peak / r_m, axis=1)}

    # ---- device files ----------------------------------------------------------------------------------------
    def device_text(self, x, note: str = "") -> str:
        """The device file of design ``x`` (V,): the shipped file with its design values replaced."""
        if self.text is None:
            raise ValueError(f"{self.device_name}: the device has no file to write designs from")
        changes: dict[tuple[str, int, str], float] = {}
        x = np.asarray(x, float)
        idx = int(self.motor_index(x[None])[0])
        motor = self.motors[idx] if idx >= 0 else None
        if self.kind == "bench":
            b, r0 = self.bench, self.bench["ratio"]
            vals = {k: float(v) for k, v in zip(self.vary, x)}
            r = vals.get("ratio", r0)
            I_M = motor["rotor_inertia"] if motor else b["mass_motor"] / r0**2
            B = motor["damping"] if motor and "damping" in motor else b["damping_motor"] / r0**2
            if "ratio" in vals or motor:
                vals.setdefault("mass_motor", r**2 * I_M)
                vals.setdefault("damping_motor", r**2 * B)
            for k, v in vals.items():
                changes[("bench", 0, k)] = v
        else:
            for k, v in zip(self.vary, x):
                t, f = k.split(".")
                changes[("transmissions", self.serial.names.index(t), f)] = float(v)
            if motor:
                for i in range(len(self.serial.names)):
                    for key in ("rotor_inertia", "continuous_torque", "peak_torque", "torque_constant"):
                        if key in motor:
                            changes[("transmissions.motor", i, key)] = motor[key]
        return device_text(self.text, changes, note)


_SECTION = re.compile(r"^\s*(\[\[?)\s*([A-Za-z0-9_.]+)\s*\]\]?")
_KEY = re.compile(r"^(\s*)([A-Za-z0-9_]+)(\s*=\s*)([^#\n]*?)(\s*(#.*)?)$")


def device_text(text: str, changes: dict, note: str = "") -> str:
    """``text`` (a TOML device file) with ``changes`` {(section, occurrence, key): value} applied in place
    (comments kept; ``[transmissions.motor]`` counts with its ``[[transmissions]]``); KeyError naming a key the
    file does not have. ``note`` becomes a comment line at the top."""
    lines = text.splitlines()
    section, count = "", {}
    done = set()
    for k, line in enumerate(lines):
        m = _SECTION.match(line)
        if m:
            section = m.group(2)
            if m.group(1) == "[[":
                count[section] = count.get(section, -1) + 1
            continue
        km = _KEY.match(line)
        if not km:
            continue
        occ = count.get(section.split(".")[0], 0) if section.startswith("transmissions") else 0
        key = (section, occ, km.group(2))
        if key in changes:
            lines[k] = f"{km.group(1)}{km.group(2)}{km.group(3)}{changes[key]!r}{km.group(5)}"
            if "#" in km.group(5):
                lines[k] = lines[k].split("#")[0].rstrip() + "  # [DESIGN] tendyn design"
            done.add(key)
    missing = set(changes) - done
    if missing:
        raise KeyError(f"not in the device file: {sorted(missing)}")
    head = [f"# {line}" for line in note.splitlines()] if note else []
    return "\n".join(head + lines) + "\n"
