"""The identification model of a rigid device: standard parameters in Khalil's order, the regressor of all
samples (C++ core), and the base (minimum) parameters with their regroupings.

Standard parameters, per link j of the tree (file joint number j), in Khalil's order and names
``XXj XYj XZj YYj YZj ZZj MXj MYj MZj Mj`` (inertia about the origin of frame j [kg·m²], first moments
[kg·m], mass [kg]), then for an actuated joint ``IAj FVj FSj OFFSETj`` (rotor inertia seen at the joint
[kg·m²], viscous [N·m·s/rad] and Coulomb [N·m] friction at the joint, torque offset [N·m]); a motor whose
angle depends on several joints (a coupling: the TX40's motor 6) adds its motor-side terms named after it,
``IAm6 FVm6 FSm6`` (motor side [kg·m²], [N·m·s/rad], [N·m]), and has no joint-side IA. At a prismatic
joint (and its linear motor) these terms are a mass [kg], N·s/m and N (:data:`PRISMATIC_UNITS`); its log
columns are in m, m/s and N (``meta.units`` of the log).

Pinocchio orders a link's parameters ``M MX MY MZ XX XY YY XZ YZ ZZ``: :func:`khalil_from_pinocchio` and
:func:`pinocchio_from_khalil` convert.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import os

import numpy as np
import scipy.linalg

from tendyn.device import compile_device
from tendyn.device.rigid_body import (UNITS, joint_frames, standard_parameters, tree_joint_numbers,  # noqa: F401
                                      unit_of)

__all__ = ["IdentModel", "KHALIL", "PINOCCHIO", "khalil_from_pinocchio", "pinocchio_from_khalil"]

KHALIL = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")
"""Khalil's order of the 10 inertial parameters of a link."""
PINOCCHIO = ("M", "MX", "MY", "MZ", "XX", "XY", "YY", "XZ", "YZ", "ZZ")
"""Pinocchio's order (``computeJointTorqueRegressor``, ``Inertia.toDynamicParameters``)."""
PRISMATIC_UNITS = {"IA": "kg", "FV": "N·s/m", "FS": "N", "OFFSET": "N", "IAm": "kg (motor side)",
                   "FVm": "N·s/m (motor side)", "FSm": "N (motor side)"}
"""Units of the joint and motor terms of a prismatic joint (the link terms keep theirs)."""
_K_FROM_P = np.array([PINOCCHIO.index(n) for n in KHALIL])
_P_FROM_K = np.array([KHALIL.index(n) for n in PINOCCHIO])

def khalil_from_pinocchio(x) -> np.ndarray:
    """Inertial parameters (…, 10 n) from Pinocchio's order to Khalil's, link by link (last axis)."""
    x = np.asarray(x, float)
    n = x.shape[-1] // 10
    return x.reshape(x.shape[:-1] + (n, 10))[..., _K_FROM_P].reshape(x.shape)


def pinocchio_from_khalil(x) -> np.ndarray:
    """Inverse of :func:`khalil_from_pinocchio`."""
    x = np.asarray(x, float)
    n = x.shape[-1] // 10
    return x.reshape(x.shape[:-1] + (n, 10))[..., _P_FROM_K].reshape(x.shape)


@dataclass(frozen=True)
class BaseSet:
    """Base parameters: ``names`` (``ZZ1R``), kept standard columns ``columns`` (index in the standard list),
    ``combination`` (b, n_std) with x_base = combination @ x_std, ``rank``."""

    names: tuple[str, ...]
    columns: tuple[int, ...]
    combination: np.ndarray
    rank: int

    def expression(self, i: int, standard_names, tol: float = 1e-9) -> str:
        """``"ZZ1 + 1.0*IA1 + 1.0*YY2"``: the regrouping of base parameter i."""
        row = self.combination[i]
        k0 = self.columns[i]
        parts = [standard_names[k0]]
        for k in np.flatnonzero(np.abs(row) > tol):
            if k == k0:
                continue
            c = float(row[k])
            txt = f"{abs(c):.6g}"
            txt = txt if any(ch in txt for ch in ".en") else txt + ".0"
            parts.append(f"{'-' if c < 0 else '+'} {txt}*{standard_names[k]}")
        return " ".join(parts)


class IdentModel:
    """The identification model of a serial device (``[[actuators]]``, ``[[drives]]`` or ``[[transmissions]]``).

    Parameters
    ----------
    device : Device or CompiledDevice
    """

    def __init__(self, device):
        from tendyn import _core

        self.threads = None         # core threads of the regressor when not given (None: every CPU; a worker's own)
        self.compiled = compile_device(device)
        self.device = self.compiled.device
        self.rigid_body = self.compiled.rigid_body
        self._data = _core.RigidBodyData(self.rigid_body)
        L, c = self.compiled.active_map
        self.L = np.ascontiguousarray(L, float)
        self.c = np.ascontiguousarray(c, float)
        self.G = np.ascontiguousarray(self.device.motor_joint_matrix(), float)
        self.joint_offsets = self.device.joint_offsets()
        numbers = tree_joint_numbers(self.device)
        self.tree_numbers = numbers
        self.active_numbers = [numbers[k] for k in self.compiled.active_joints]
        self.n_active = len(self.active_numbers)
        self.n_motors = self.G.shape[0]
        self.motor_joints = self._motor_joints()
        self.prismatic_numbers = frozenset(num for num, f in zip(numbers, joint_frames(self.device)) if f.prismatic)
        self.terms = self.compiled.terms
        self.raw_names, self.standard_columns, self.standard_names = self._columns()
        self.n_rigid = len(self.standard_columns)

    # -- columns --------------------------------------------------------------------------------------
    def _motor_joints(self) -> list[int]:
        dev = self.device
        if dev.actuators:
            return [a.joint for a in dev.actuators]
        if dev.drives:
            return [d.joint for d in dev.drives]
        return [t.joint for t in dev.transmissions]

    def coupled_motors(self) -> list[int]:
        """0-based motors whose angle depends on more than one joint (motor-side terms identifiable)."""
        return [i for i in range(self.n_motors) if np.count_nonzero(np.abs(self.G[i]) > 1e-12) > 1]

    def _columns(self):
        nt = len(self.tree_numbers)
        raw = []
        for num in self.tree_numbers:
            raw += [f"{p}{num}" for p in PINOCCHIO]
        for num in self.active_numbers:
            raw += [f"{p}{num}" for p in ("IA", "FV", "FS", "OFFSET")]
        for j in self.motor_joints:
            raw += [f"{p}{j}" for p in ("IAm", "FVm", "FSm")]
        idx = {n: k for k, n in enumerate(raw)}
        coupled = {self.motor_joints[i] for i in self.coupled_motors()}
        std = []
        for num in self.tree_numbers:
            std += [f"{p}{num}" for p in KHALIL]
            if num in self.active_numbers:
                std += [f"{p}{num}" for p in (("FV", "FS", "OFFSET") if num in coupled else ("IA", "FV", "FS", "OFFSET"))]
            if num in coupled:
                std += [f"{p}{num}" for p in ("IAm", "FVm", "FSm")]
        assert 10 * nt + 4 * self.n_active + 3 * self.n_motors == len(raw)
        clash = set(self.terms.names) & set(std)
        if clash:
            raise ValueError(f"{self.device.name}: term column {sorted(clash)[0]!r} has the name of a standard "
                             "parameter: rename the term")
        return raw, np.array([idx[n] for n in std]), tuple(std) + self.terms.names

    def prior(self) -> np.ndarray:
        """Standard parameters of the device file (URDF inertias, motor priors) in :attr:`standard_names` order."""
        names, values = standard_parameters(self.device)   # Pinocchio order, names "M1", "MX1", ...
        val = dict(zip(names, values))
        dev = self.device
        for k, j in enumerate(self.motor_joints):
            g = self.G[k]
            if dev.actuators:
                a = dev.actuators[k]
                ir, fv, fs = a.rotor_inertia, a.viscous_motor, a.coulomb_motor
            elif dev.drives:
                d = dev.drives[k]
                ir, fv, fs = d.motor.rotor_inertia, d.viscous_motor, d.coulomb_motor
                val[f"OFFSET{j}"] = d.offset_joint
            else:
                ir, fv, fs = dev.transmissions[k].motor.rotor_inertia, 0.0, 0.0
            if k in self.coupled_motors():
                val.update({f"IAm{j}": ir, f"FVm{j}": fv, f"FSm{j}": fs})
            else:
                n = g[np.flatnonzero(np.abs(g) > 1e-12)[0]]
                val.update({f"IA{j}": n * n * ir, f"FV{j}": n * n * fv, f"FS{j}": abs(n) * fs})
        val.update(zip(self.terms.names, self.terms.values))
        return np.array([val.get(n, 0.0) for n in self.standard_names])

    def unit(self, name: str) -> str:
        """The unit of a standard or base parameter of this device: :func:`unit_of`, or for the joint and motor
        terms of a prismatic joint :data:`PRISMATIC_UNITS` (``FV1`` of a linear axis → N·s/m); a term's
        column (``[[terms]]``) the unit of :class:`tendyn.device.terms.TermModel`."""
        for key in (name, name[:-1] if name.endswith("R") else None):
            if key in self.terms.names:
                return self.terms.units[self.terms.names.index(key)]
        stem = name.rstrip("R").rstrip("0123456789")
        num = name.rstrip("R")[len(stem):]
        if num and int(num) in self.prismatic_numbers and stem in PRISMATIC_UNITS:
            return PRISMATIC_UNITS[stem]
        return unit_of(name)

    def check_units(self, units: dict) -> None:
        """A motor of a prismatic joint logs m, m/s, N; any other motor rad, rad/s, N·m (``meta.units``).

        units : column name → unit (:attr:`Log.units`, or a Parquet file's field units)."""
        from tendyn.io.logs import LINEAR_UNITS, LogError

        for i, j in enumerate(self.motor_joints):
            linear = j in self.prismatic_numbers
            for name in (f"q_motor_{i + 1}", f"qd_motor_{i + 1}", f"torque_motor_{i + 1}"):
                if name not in units:
                    continue
                if (units[name] in LINEAR_UNITS.values()) != linear:
                    want = ("m, m/s, N" if linear else "rad, rad/s, N·m")
                    raise LogError(f"unit {units[name]!r}: motor {i + 1} drives the "
                                   f"{'prismatic' if linear else 'revolute'} joint {j} of {self.device.name}, "
                                   f"whose columns are in {want}"
                                   + (" (declare `unit = \"m\"` / \"N\" in the import map, or meta.units)"
                                      if linear else ""), column=name)

    # -- regressor ------------------------------------------------------------------------------------
    def regressor(self, q, qd, qdd, taps=(1.0,), K: int = 1, columns=None, threads: int | None = None) -> np.ndarray:
        """Observation matrix of all samples, joint-major rows, filtered by ``taps`` and decimated by ``K``.

        Parameters
        ----------
        q, qd, qdd : (n, n_active) active positions [rad], velocities [rad/s], accelerations [rad/s²].
        taps : symmetric FIR of odd length (the parallel filter; (1,) = none); K : decimation factor.
        columns : None for the standard parameters (:attr:`standard_names`, the ``[[terms]]`` columns last), or
            indices into them.
        threads : core threads (None: :attr:`threads`, else the CPUs this process may use); the result does not
            depend on it.

        Returns
        -------
        ndarray (n_active * n_out, n_columns)
        """
        from tendyn import _core

        f = lambda x: np.ascontiguousarray(x, float)
        W = _core.identification_regressor(self.rigid_body, self._data, self.L, self.c, self.G, f(q), f(qd),
                                           f(qdd), np.asarray(taps, float), int(K),
                                           int(threads or self.threads or len(os.sched_getaffinity(0))))
        if not len(self.terms):
            cols = self.standard_columns if columns is None else self.standard_columns[np.asarray(columns)]
            return W[:, cols]
        W = np.hstack([W[:, self.standard_columns], self.term_rows(q, taps, K)])
        return W if columns is None else W[:, np.asarray(columns)]

    def term_rows(self, q, taps=(1.0,), K: int = 1) -> np.ndarray:
        """The ``[[terms]]`` columns of the regressor (n_active * n_out, n_terms), joint-major rows, through
        the same parallel filter and decimation as the rigid-body columns (S2 eq. 4 extended: τ = W X + Φ θ)."""
        from tendyn import _core

        Phi = self.terms.columns(q)                    # (n, na, c)
        n, na, c = Phi.shape
        dec = _core.fir_decimate(np.asarray(taps, float), int(K), np.ascontiguousarray(Phi.reshape(n, na * c)))
        n_out = dec.shape[0]
        return dec.reshape(n_out, na, c).transpose(1, 0, 2).reshape(na * n_out, c)

    def known_torque(self, q) -> np.ndarray | None:
        """Joint torques (n, n_active) of the ``known`` terms at active positions q, to subtract from the
        measured ones; None when the device has none."""
        return self.terms.known(q) if self.terms.has_known else None

    def _ranges(self):
        """Active joint limits (lo, hi) [rad or m] (±π where the file gives none)."""
        js = [self.device.kinematics.joints[num - 1] for num in self.active_numbers]
        lo = np.array([j.lower if j.lower is not None else -np.pi for j in js])
        hi = np.array([j.upper if j.upper is not None else np.pi for j in js])
        return lo, hi

    # -- base parameters ------------------------------------------------------------------------------
    def _preference(self) -> list[int]:
        names = self.standard_names
        idx = {n: k for k, n in enumerate(names)}
        order = []
        for group in (("XX", "XY", "XZ", "YZ", "ZZ", "MX", "MY"), ("MZ", "M", "YY"), ("IAm", "FVm", "FSm"),
                      ("IA",), ("FV", "FS", "OFFSET")):
            for num in self.tree_numbers:
                order += [idx[f"{p}{num}"] for p in group if f"{p}{num}" in idx]
        return order + [idx[n] for n in self.terms.names]   # a term regrouped into a link's parameter, not back

    @cached_property
    def base(self) -> BaseSet:
        """The base parameters, found numerically (random samples, QR in a preference order, Gautier 1991)."""
        rng = np.random.default_rng(0)
        n, na = 60, self.n_active
        W = self.regressor(rng.uniform(-np.pi, np.pi, (n, na)), rng.normal(size=(n, na)),
                           rng.normal(size=(n, na)))
        if len(self.terms):    # tables and polynomials are exercised inside the joint ranges too
            lo, hi = self._ranges()
            W = np.vstack([W, self.regressor(rng.uniform(lo, hi, (n, na)), rng.normal(size=(n, na)),
                                             rng.normal(size=(n, na)))])
        tol = 1e-8
        norms = np.linalg.norm(W, axis=0)
        nonzero = norms > tol * norms.max()
        Wn = np.where(nonzero, W / np.where(nonzero, norms, 1.0), 0.0)
        _, Rp, _ = scipy.linalg.qr(Wn, mode="economic", pivoting=True)
        rank = int(np.sum(np.abs(np.diag(Rp)) > tol * abs(Rp[0, 0])))
        order = self._preference()
        _, R = np.linalg.qr(Wn[:, order])
        base = [order[k] for k in range(len(order)) if nonzero[order[k]] and abs(R[k, k]) > tol]
        if len(base) != rank:
            raise RuntimeError(f"base-parameter selection found {len(base)} columns, rank {rank}")
        base.sort()
        other = [k for k in range(W.shape[1]) if k not in base]
        beta, *_ = np.linalg.lstsq(W[:, base], W[:, other], rcond=None)
        beta[np.abs(beta) < 1e-9] = 0.0
        comb = np.zeros((len(base), W.shape[1]))
        for i, k in enumerate(base):
            comb[i, k] = 1.0
            comb[i, other] = beta[i]
        names = tuple(self.standard_names[k] + ("R" if np.count_nonzero(comb[i]) > 1 else "")
                      for i, k in enumerate(base))
        return BaseSet(names=names, columns=tuple(base), combination=comb, rank=rank)

    # -- identified values back into the model ----------------------------------------------------------
    def parameter_vector(self, params) -> np.ndarray:
        """Identified base parameters as a vector over :attr:`standard_names` (so W x = W_b x_b): each value
        at the column of the first term of its expression (the standard column kept, the others regrouped into
        it), 0 elsewhere.

        params : list of {name, value, expression} (the ``params`` of ``tendyn identify --json``).
        Raises ValueError naming ``params[i].expression`` for a column this device does not have or uses twice.
        """
        idx = {n: k for k, n in enumerate(self.standard_names)}
        x = np.zeros(len(self.standard_names))
        used = set()
        for i, p in enumerate(params):
            lead = str(p["expression"]).split()[0].lstrip("+")
            if lead not in idx:
                raise ValueError(f"params[{i}].expression: {lead!r} is not a standard parameter of "
                                 f"{self.device.name} (known: {', '.join(self.standard_names[:6])}, …)")
            if idx[lead] in used:
                raise ValueError(f"params[{i}].expression: two parameters use the column {lead}")
            used.add(idx[lead])
            x[idx[lead]] = float(p["value"])
        return x

    def inertial_columns(self) -> np.ndarray:
        """Mask over :attr:`standard_names` of the inertial parameters (links, IA, IAm): not FV, FS, OFFSET,
        FVm, FSm."""
        return np.array([n.rstrip("0123456789") not in ("FV", "FS", "OFFSET", "FVm", "FSm")
                         and n not in self.terms.names for n in self.standard_names])

    def mass_matrix(self, q, x) -> np.ndarray:
        """A(q) [kg·m²] (n_active × n_active, rotors included) of the standard-order parameters x: column i is
        W(q, 0, e_i) x − W(q, 0, 0) x over the inertial columns (gravity cancels; friction and offsets left out).

        q : (n_active,) [rad]; x : (n_standard,) e.g. :meth:`parameter_vector` or :meth:`prior`."""
        na = self.n_active
        q = np.tile(np.asarray(q, float), (na + 1, 1))
        qdd = np.vstack([np.eye(na), np.zeros(na)])
        xi = np.where(self.inertial_columns(), np.asarray(x, float), 0.0)
        tau = (self.regressor(q, np.zeros_like(q), qdd, threads=1) @ xi).reshape(na, na + 1)   # joint-major rows
        return tau[:, :na] - tau[:, na:]

    # -- log signals ----------------------------------------------------------------------------------
    def joint_signals(self, log):
        """Active joint positions [rad] and joint torques [N·m] of a log's motor signals.

        q = G⁻¹ q_motor + encoder offsets; τ = Gᵀ y with y the motor torques (``torque_motor_<i>``, or
        ``current_<i>`` × torque constant). Returns (time [s], q (n, n_a), tau (n, n_a)).
        """
        from tendyn.io.logs import LogError

        nm = self.n_motors
        self.check_units(log.units)
        try:
            qm = log.stack("q_motor_")
        except (KeyError, ValueError) as exc:
            raise LogError(f"identification needs the motor positions q_motor_1…q_motor_{nm}: {exc}") from None
        if qm.shape[1] != nm:
            raise LogError(f"the log has {qm.shape[1]} motor positions, the device {self.device.name} has {nm} motors",
                           column="q_motor_")
        if log.column_names("torque_motor_") and "torque_motor_1" in log:
            y = log.stack("torque_motor_")
        elif log.column_names("current_"):
            kt = np.array([a.torque_constant for a in self.device.actuators]) if self.device.actuators else \
                np.array([d.motor.torque_constant for d in (self.device.drives or self.device.transmissions)])
            y = log.stack("current_") * kt
        else:
            raise LogError("identification needs the motor torques torque_motor_1… (or current_1…)",
                           column="torque_motor_")
        if y.shape[1] != nm:
            raise LogError(f"the log has {y.shape[1]} motor torques, the device has {nm} motors", column="torque_motor_")
        q = np.linalg.solve(self.G, qm.T).T + self.joint_offsets
        tau = y @ self.G
        return log.time, q, tau

    @property
    def elastic_drives(self) -> bool:
        """Whether the device's capstan ``[[drives]]`` declare a finite cable stiffness (``stiffness_motor`` > 0):
        then the motor encoders do not read the link (:meth:`link_positions`). The device owns the test
        (:attr:`tendyn.device.serial_device.SerialDevice.elastic_drives`)."""
        return bool(getattr(self.device, "elastic_drives", False))

    def link_positions(self, q, tau, rate_hz: float, cutoff_hz: float, order: int, coulomb_motor, viscous_motor):
        """Link positions [rad] (n, n_a) of the motor-encoder positions q = q_m / N of elastic capstan drives.

        The cable between motor and link (S2 §V-B, the twin's drive: τ_c = K_T (q_m − N q_l) at the motor) stretches
        by s = τ_c / K_T, with τ_c from the motor's own equation τ_c = τ_m − J_m q̈_m − C_m sign(q̇_m) − ν_m q̇_m
        (torque and q̈_m through the treatment's zero-phase Butterworth ``cutoff_hz`` [Hz], ``order``); the link is
        at q_l = (q_m − s) / N. The rigid model evaluated on q_m / N instead misses M (q̈_l − q̈_m / N): an error
        (ω / ω_r)² of the cable torque, ω_r the link–cable resonance, which least squares books largely on the
        viscous terms (+20…+90 % on generated desktop arms, tests/python/test_parallelogram_twin.py). J_m and
        K_T are the device file's; ``coulomb_motor`` C_m [N·m] and ``viscous_motor`` ν_m [N·m·s/rad] (n_m,) come
        from a first fit (the file's friction is never read). The cable damping ``damping_motor`` is neglected
        (valid while d ω ≪ K_T)."""
        from .treatment import butter_zero_phase, central_differences

        N = np.array([d.ratio for d in self.device.drives], float)
        K = np.array([d.stiffness_motor for d in self.device.drives], float)
        J = np.array([d.motor.rotor_inertia for d in self.device.drives], float)
        qm = (np.asarray(q, float) - self.joint_offsets) * N
        ym = np.asarray(tau, float) / N                     # G = diag(N): τ = y G
        dt = 1.0 / rate_hz
        qmf = butter_zero_phase(qm, cutoff_hz, rate_hz, order)
        qdm = central_differences(qmf, dt)
        qddm = central_differences(qdm, dt)
        tc = (butter_zero_phase(ym, cutoff_hz, rate_hz, order) - J * qddm
              - np.asarray(coulomb_motor, float) * np.sign(qdm) - np.asarray(viscous_motor, float) * qdm)
        return (qm - tc / K) / N + self.joint_offsets

    def motor_torques(self, tau) -> np.ndarray:
        """Motor torques y = G⁻ᵀ τ (n, n_m) [N·m, N at a linear motor] of joint torques τ (n, n_a), one row per
        sample: the motor space of a coupled device (``tendyn.coupling``: motor_from_joint_torque)."""
        return np.linalg.solve(self.G.T, np.asarray(tau, float).T).T

    def joint_velocities(self, log):
        """Logged active joint velocities [rad/s] (n, n_a), or None when the log has none.

        From the motor velocities ``qd_motor_<i>`` (q̇ = G⁻¹ q̇_motor), else from ``qd_joint_<j>`` of every
        active joint j (file joint numbers)."""
        from tendyn.io.logs import LogError

        found = log.column_names("qd_motor_")
        if found and len(found) != self.n_motors:
            raise LogError(f"the log has {len(found)} motor velocities, the device {self.device.name} has "
                           f"{self.n_motors} motors", column="qd_motor_")
        names = self.velocity_columns(log.columns)
        if names is None:
            return None
        v = np.column_stack([log[n] for n in names])
        return np.linalg.solve(self.G, v.T).T if names[0].startswith("qd_motor_") else v

    def velocity_columns(self, names) -> list[str] | None:
        """The logged-velocity columns among ``names`` that :meth:`joint_velocities` reads: ``qd_motor_<i>`` of
        every motor, else ``qd_joint_<j>`` of every active joint; None: none (the one rule, in memory and
        streamed)."""
        names = set(names)
        motor = [f"qd_motor_{i + 1}" for i in range(self.n_motors)]
        if all(n in names for n in motor):
            return motor
        joint = [f"qd_joint_{n}" for n in self.active_numbers]
        return joint if all(n in names for n in joint) else None

    def no_logged_velocities(self):
        """The error of ``--velocities logged`` on a log without them."""
        from tendyn.io.logs import LogError

        return LogError(f"logged velocities asked for, but the log has no qd_motor_1…qd_motor_{self.n_motors} "
                        f"(nor qd_joint_<j> of every active joint)", column="qd_motor_")


_MODELS: dict = {}


def diagonal_coupling(G) -> bool:
    """Whether each motor drives one joint and each joint one motor (G a scaled permutation): then joint and
    motor space differ by a gain per axis and their relative residuals are the same."""
    G = np.asarray(G, float)
    nz = np.abs(G) > 1e-12
    return G.shape[0] == G.shape[1] and bool(np.all(nz.sum(axis=0) == 1) and np.all(nz.sum(axis=1) == 1))


def cached_model(device) -> IdentModel:
    """The IdentModel of a device, built once per process per device file (its base parameters cost a QR).

    Keyed by the device file and the modification times of it and its URDF, so an edited file is rebuilt.
    """
    from tendyn.device.compiled import as_device

    dev = as_device(device)
    path = getattr(dev, "path", None)
    urdf = getattr(getattr(dev, "kinematics", None), "urdf", None)
    try:
        key = (str(path), path.stat().st_mtime_ns, str(urdf), urdf.stat().st_mtime_ns if urdf else 0)
    except (OSError, AttributeError):
        return IdentModel(device)
    if key not in _MODELS:
        _MODELS[key] = IdentModel(device)
    return _MODELS[key]
