"""N+1 tendons: n + 1 tendons share the n joints of a device (issue 19; docs/device-file.md, "N+1 routings").

The computing model is the core's ``TendonModel`` (``include/tendyn/tendons.hpp``): tendon velocities ℓ̇ = K q̇
[m/s], joint torques τ = Kᵀ t [N·m] from tensions t ≥ 0 [N] (virtual work), motor torques C_m = R_m t [N·m], and
the feedforward t = P τ + λ h: the minimum-norm tensions P τ (P = pinv(Kᵀ)) plus the least internal tension λ
[N] along the null vector h (Kᵀh = 0, max 1, h > 0: tension closure) that keeps every tension at or above its
floor (the device file's ``pretension`` of each tendon). Given the joint velocities, the branch losses of S0 eq. 12
(τ0 sgn(Ṡ) + ν Ṡ per branch) are climbed along each tendon and the floors hold at every point of it.

>>> from tendyn.devices import bundled
>>> from tendyn.device import load_device
>>> t = Tendons.from_device(load_device(bundled("tendon_finger")))
>>> t.m, t.n
(4, 3)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tendyn import _core


@dataclass(frozen=True)
class TendonForces:
    """One feedforward: ``tension`` (m,) [N] at the motors, ``motor_torque`` (m,) [N·m] = R_m t,
    ``internal_tension`` λ [N] (the scale of h added to the minimum-norm tensions), ``tension_joint`` (m, n) [N]
    (tendon i at joint j, 0 past its last joint) and ``tension_end`` (m,) [N] (at its last joint); every tension
    along every tendon ≥ its floor. Lossless, all three are equal."""

    tension: np.ndarray
    motor_torque: np.ndarray
    internal_tension: float
    tension_joint: np.ndarray
    tension_end: np.ndarray


class Tendons:
    """The N+1 tendons of a device, on the C++ core (``tendyn._core.TendonModel``).

    Build with :meth:`from_device` (a device with ``[device] routing = "n_plus_one"``) or :meth:`from_arrays`.
    ``names`` are the tendons (transmission names) in the order the device holds them (sorted by the joint they
    end on, the file's order among those ending on one joint).
    """

    def __init__(self, model, names=None, device: str = "", peak_tension=None):
        self.model = model
        self.names = tuple(names) if names is not None else tuple(f"tendon{i + 1}" for i in range(model.m))
        self.device = device
        self.peak_tension = None if peak_tension is None else np.asarray(peak_tension, float)
        """(m,) [N] the motors' peak tensions peak_torque / motor_radius (from a device), or None."""
        self._data = _core.TendonData(model)

    @classmethod
    def from_arrays(cls, K, motor_radius, tension_min=None, names=None) -> "Tendons":
        """K (n + 1, n) [m], motor radii (n + 1,) [m], tension floors (n + 1,) [N] (default 0). ValueError (from
        the core, 0-based tendon) when K is rank deficient or has no tension closure."""
        K = np.asarray(K, float)
        r_m = np.asarray(motor_radius, float)
        t_min = np.zeros(K.shape[0]) if tension_min is None else np.asarray(tension_min, float)
        return cls(_core.TendonModel(K, r_m, t_min), names)

    @classmethod
    def from_device(cls, device) -> "Tendons":
        """The tendons of an N+1 device (ValueError for any other device)."""
        if getattr(device, "routing", None) != "n_plus_one":
            raise ValueError(f"{device.name}: not an N+1 device ([device] routing = \"n_plus_one\")")
        from tendyn.device.routing_checks import tendon_model

        trans = device.transmissions
        return cls(tendon_model(trans, device.n_joints), [t.name for t in trans], device.name,
                   [t.motor.peak_torque / t.motor_radius for t in trans])

    # ---- the model --------------------------------------------------------------------------
    @property
    def n(self) -> int:
        return self.model.n

    @property
    def m(self) -> int:
        return self.model.m

    @property
    def K(self) -> np.ndarray:
        """(m, n) [m]: ℓ̇ = K q̇."""
        return np.array(self.model.K)

    @property
    def motor_radius(self) -> np.ndarray:
        return np.array(self.model.motor_radius)

    @property
    def tension_min(self) -> np.ndarray:
        return np.array(self.model.tension_min)

    @property
    def null_vector(self) -> np.ndarray:
        """h (m,) [-]: Kᵀh = 0, max h = 1, h > 0 (tension closure)."""
        return np.array(self.model.null_vector)

    @property
    def tension_from_torque(self) -> np.ndarray:
        """P = pinv(Kᵀ) (m, n) [1/m]: the minimum-norm tensions P τ."""
        return np.array(self.model.tension_from_torque)

    # ---- the calls ---------------------------------------------------------------------------
    def feedforward(self, tau, qd=None) -> TendonForces:
        """Joint torques τ (n,) [N·m] → tensions ≥ floors [N] and motor torques [N·m]; with the joint velocities
        q̇ (n,) [rad/s], the branch losses of S0 eq. 12 along each tendon (None: lossless, every branch at rest)."""
        _core.tendon_feedforward(self.model, np.asarray(tau, float), self._data,
                                 None if qd is None else np.asarray(qd, float))
        d = self._data
        return TendonForces(np.array(d.tension), np.array(d.motor_torque), float(d.internal_tension),
                            np.array(d.tension_joint), np.array(d.tension_end))

    def joint_torque(self, tension) -> np.ndarray:
        """Tensions (m,) [N] → joint torques Kᵀ t (n,) [N·m]."""
        return np.asarray(_core.tendon_joint_torque(self.model, np.asarray(tension, float)))

    def tendon_velocity(self, qd) -> np.ndarray:
        """Joint velocities (n,) [rad/s] → tendon velocities K q̇ (m,) [m/s]."""
        return np.asarray(_core.tendon_velocity(self.model, np.asarray(qd, float)))

    def motor_velocity(self, qd) -> np.ndarray:
        """Joint velocities (n,) [rad/s] → motor velocities ℓ̇ / r_m (m,) [rad/s]."""
        return self.tendon_velocity(qd) / self.motor_radius

    def minimum_pretension(self, tau_max) -> float:
        """Least internal tension λ [N] (scale of h) that keeps every tension ≥ its floor for every joint torque
        in the box |τ_j| ≤ tau_max_j [N·m] (a scalar applies to every joint)."""
        lim = np.broadcast_to(np.abs(np.asarray(tau_max, float)), (self.n,)).copy()
        return float(self.model.minimum_pretension(lim))

    def largest_torque_box(self, peak_tension=None) -> float:
        """Largest s [N·m] such that, with the pretension λ(s) of the box |τ_j| ≤ s, every tension stays at or
        below its peak [N] for every τ in the box: t_i ≤ s a_i + λ(s) h_i with a_i = Σ_j |P_ij| and
        λ(s) = max_k (t_min,k + s a_k) / h_k, so s = min over i, k of (peak_i − h_i t_min,k / h_k) /
        (a_i + h_i a_k / h_k) (0 when the floors alone exceed a peak). Needs peak tensions (from a device)."""
        peak = self.peak_tension if peak_tension is None else np.asarray(peak_tension, float)
        if peak is None:
            raise ValueError("largest_torque_box needs the peak tensions [N] (Tendons.from_device gives them)")
        a = np.abs(self.tension_from_torque).sum(axis=1)
        h, t_min = self.null_vector, self.tension_min
        ratio = h[:, None] / h[None, :]                       # [i, k] = h_i / h_k
        s = (peak[:, None] - ratio * t_min[None, :]) / (a[:, None] + ratio * a[None, :])
        return float(max(0.0, s.min()))

    def to_dict(self, tau_max=None) -> dict:
        out = {"tendons": list(self.names), "K": self.K.tolist(), "motor_radius": self.motor_radius.tolist(),
               "tension_min": self.tension_min.tolist(), "null_vector": self.null_vector.tolist(),
               "tension_from_torque": self.tension_from_torque.tolist(), "condition": float(self.model.condition)}
        if tau_max is not None:
            lim = np.broadcast_to(np.abs(np.asarray(tau_max, float)), (self.n,))
            lam = self.minimum_pretension(lim)
            out.update({"max_joint_torque": lim.tolist(), "minimum_pretension": lam,
                        "tension_at_minimum_pretension": (lam * self.null_vector).tolist()})
        return out
