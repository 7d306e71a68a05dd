"""A validated serial (or tree) device: :class:`SerialDevice` (its joints, transmissions or capstan drives,
actuators and terms, and the routing arrays the core reads), and the refusal of N+1 devices where one cable
per joint is needed (:func:`require_one_per_joint`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

import numpy as np

from .base import Device, DeviceError
from .core_fields import BEARING_ARRAY_NAMES, BEARING_PREFIX, TRANSMISSION_MODEL_FIELDS
from .schema_fields import FRICTION_FIELDS
from .schema_parts import Actuator, Drive, Kinematics, Term, TransmissionSpec

@dataclass(frozen=True, eq=False)
class SerialDevice(Device):
    """A validated serial (or tree) device description (see :func:`tendyn.device.load_device`).

    name, description : str
    path : Path of the device file
    kinematics : :class:`Kinematics`
    transmissions : tuple of :class:`TransmissionSpec`, sorted by driven joint (empty for a drive device); an N+1
        routing holds n + 1 of them, those ending on the same joint in the file's order
    routing : "one_per_joint" or "n_plus_one" (``[device] routing``)
    drives : tuple of :class:`Drive`, sorted by driven joint (empty for a transmission device)
    actuators : tuple of :class:`Actuator` in the file's order: motor i is the i-th ``[[actuators]]`` entry
    kind : "serial" (class attribute; see :class:`tendyn.device.base.Device`)
    experiments : the experiments of a chain twin (class attribute)
    """

    name: str
    description: str
    path: Path
    kinematics: Kinematics
    transmissions: tuple[TransmissionSpec, ...] = field(default_factory=tuple)
    drives: tuple[Drive, ...] = field(default_factory=tuple)
    actuators: tuple[Actuator, ...] = field(default_factory=tuple)
    bandwidth_hz: float | None = None
    home_pose: tuple | None = None
    routing: str = "one_per_joint"
    terms: tuple[Term, ...] = field(default_factory=tuple)
    kind: ClassVar[str] = "serial"
    experiments: ClassVar[tuple[str, ...]] = ("constant-velocity", "exciting", "blocked-link", "stepped-sine",
                                              "swept-sine")

    @property
    def source(self) -> str:
        """The device file, as text."""
        return str(self.path)

    @property
    def n_joints(self) -> int:
        """Number of joints of the kinematic description."""
        return self.kinematics.n_joints

    @property
    def n_transmissions(self) -> int:
        return len(self.transmissions)

    @property
    def elastic_drives(self) -> bool:
        """True when the device's capstan ``[[drives]]`` declare a finite cable stiffness (``stiffness_motor`` > 0):
        the motor encoders do not read the link, the dry friction sits at the motor behind the cable spring (S2
        Fig. 4). The one test of it: identification's velocity threshold and drive-stretch refit
        (``tendyn.ident.model``) and the twin's default exciting design (``tendyn.sim.experiments``) read it."""
        return bool(self.drives) and all(d.stiffness_motor > 0.0 for d in self.drives)

    @property
    def n_plus_one(self) -> bool:
        """True for an N+1 routing (``[device] routing = "n_plus_one"``): n + 1 tendons on n actuated joints."""
        return self.routing == "n_plus_one"

    def motor_joint_matrix(self) -> np.ndarray:
        """G (n_motors, n_active) [rad/rad] with q_motor = G q_active (active joints in tree order).

        The one matrix the three actuation kinds build, so identification and a later generalisation
        (rectangular couplings, differentials) share it: ``[[actuators]]`` give G = diag(N) (I + coupling);
        ``[[drives]]`` G = diag(N); ``[[transmissions]]`` G = R_m^-1 K restricted to the active joints
        (cable routing). The motor torques y map to joint torques as tau = G^T y (virtual work).
        """
        active = [num for num, js in enumerate(self.kinematics.joints, start=1) if js.actuated and js.sigma != 2]
        col = {num: k for k, num in enumerate(active)}
        if self.actuators:
            G = np.zeros((len(self.actuators), len(active)))
            for i, a in enumerate(self.actuators):
                G[i, col[a.joint]] = a.ratio
                for jn, coef in a.coupling:
                    G[i, col[jn]] += a.ratio * coef
            return G
        if self.drives:
            G = np.zeros((len(self.drives), len(active)))
            for i, d in enumerate(self.drives):
                G[i, col[d.joint]] = d.ratio
            return G
        arr = self.routing_arrays()
        K = arr["K"][:, [num - 1 for num in active]]
        return K / arr["motor_radius"][:, None]

    def joint_offsets(self) -> np.ndarray:
        """Encoder zero offsets [rad] per active joint (0 unless ``[[actuators]]`` give them)."""
        active = [num for num, js in enumerate(self.kinematics.joints, start=1) if js.actuated and js.sigma != 2]
        off = {a.joint: a.encoder_offset for a in self.actuators}
        return np.array([off.get(num, 0.0) for num in active])

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.kinematics.joints)

    def square_routing_arrays(self, what: str) -> dict[str, np.ndarray]:
        """:meth:`routing_arrays` of a device with one cable (or antagonistic pair) per joint, for ``what`` (the
        square statics with losses, :meth:`tendyn.transmission.Transmission.from_device`); an N+1 device raises
        DeviceError naming ``what`` (:func:`require_one_per_joint`)."""
        require_one_per_joint(self, what)
        return self.routing_arrays()

    def routing_arrays(self) -> dict[str, np.ndarray]:
        """The routing and friction data as numpy arrays, 0-based.

        Rows are transmissions (sorted by driven joint), columns are joints; with one transmission per
        joint (every "dh" device) the matrices are square (n, n); lower-triangular for a serial routing, with
        entries above the diagonal for a differential (a cable that wraps joints after the one it drives).
        An antagonistic pair (``antagonistic = true``) is one row of net tension u = T_a − T_b: its two cables
        slide in opposite directions, so their losses add, and while both are taut (T_a + T_b = 2P) the
        tension-proportional part is a constant: tau0 = 2 τ₀ + 2 β P, nu = 2 ν, beta = 0 per branch.

        Returns
        -------
        dict of str to ndarray
            ``motor_radius`` (m,) [m]; ``K`` (m, n) [m] with K[i, j] the signed idle-pulley radius of
            transmission i at crossed joint j, K[i, joint_i] = generalised radius (driven_radius *
            reducer_ratio), 0 elsewhere, so that R_m q_m = K q; ``driven_radius``, ``reducer_ratio``,
            ``reducer_efficiency``, ``pretension`` (m,); ``tau0`` [N], ``nu`` [N s/m], ``beta`` [-] (m, n)
            with [i, b] = branch b of transmission i (zero past the last joint it wraps); ``bearing_count``,
            ``bearing_radius``, ``bearing_wrap``, ``bearing_static_coefficient``,
            ``bearing_dynamic_coefficient``, ``bearing_h0``, ``bearing_h1``, ``bearing_n0`` (m, n), zero where
            there is no bearing except ``bearing_radius`` = 1.0 there (no division by zero). The keys and
            their order are those of :data:`TRANSMISSION_MODEL_FIELDS` (the core model's fields).
        """
        n = self.n_joints
        m = self.n_transmissions
        out: dict[str, np.ndarray] = {}
        for f in TRANSMISSION_MODEL_FIELDS:
            out[f.name] = np.full((m, n) if f.dims == 2 else (m,), f.default, dtype=float)
        for i, t in enumerate(self.transmissions):
            for f in TRANSMISSION_MODEL_FIELDS:
                if f.dims == 1:
                    out[f.name][i] = getattr(t, f.name)
            for jn, rad in zip(t.crosses, t.crossed_radii):
                out["K"][i, jn - 1] = rad
            out["K"][i, t.joint - 1] = t.generalized_radius
            for b, fr in enumerate(t.friction):
                for spec in FRICTION_FIELDS:
                    out[spec.name][i, b] = getattr(fr, spec.name)
                if t.antagonistic:  # the pair as one transmission of net tension (docs/device-file.md)
                    out["tau0"][i, b] = 2.0 * fr.tau0 + 2.0 * fr.beta * t.pretension
                    out["nu"][i, b] = 2.0 * fr.nu
                    out["beta"][i, b] = 0.0
            for b, br in enumerate(t.bearings):
                if br is None:
                    continue
                for name in BEARING_ARRAY_NAMES:
                    out[BEARING_PREFIX + name][i, b] = getattr(br, name)
        return out


    def drive_routing_arrays(self) -> dict[str, np.ndarray]:
        """The capstan ``[[drives]]`` as one-branch cable transmissions (S0 eq. 17 with one branch per drive), for
        the statics with losses and the compensator (issue 40).

        Drive k (in file order: the simulator's and the active map's order) is transmission k with the motor
        radius r_m = :data:`DRIVE_MOTOR_RADIUS` and K[k, k] = N_k r_m, so q_k = q_m,k / N_k and the lossless motor
        torque is τ_k / N_k; the branch slides at Ṡ = r_m q̇_m, so the branch law Δτ = τ0 sgn(Ṡ) + ν Ṡ
        (losses.hpp) times r_m is the drive's motor friction C_m0 sgn(q̇_m) + ν_m q̇_m with τ0 = C_m0 / r_m [N],
        ν = ν_m / r_m² [N·s/m]. Not modelled here (the twin has
        them): the cable's elasticity and damping (the compensator reads the motor encoders, q = q_m / N) and
        ``offset_joint``. Returns the keys of :meth:`routing_arrays` with rows = columns = drives.
        """
        m = len(self.drives)
        out: dict[str, np.ndarray] = {}
        for f in TRANSMISSION_MODEL_FIELDS:
            out[f.name] = np.full((m, m) if f.dims == 2 else (m,), f.default, dtype=float)
        r = DRIVE_MOTOR_RADIUS
        out["motor_radius"][:] = r
        out["K"][:] = np.diag([d.ratio * r for d in self.drives])
        out["driven_radius"][:] = [d.ratio * r for d in self.drives]
        out["reducer_ratio"][:] = 1.0
        out["reducer_efficiency"][:] = 1.0
        out["pretension"][:] = 0.0
        out["tau0"][:] = np.diag([d.coulomb_motor / r for d in self.drives])
        out["nu"][:] = np.diag([d.viscous_motor / r ** 2 for d in self.drives])
        return out


DRIVE_MOTOR_RADIUS = 0.01
"""Motor radius [m] of the one-branch transmission a capstan drive is compensated as
(:meth:`SerialDevice.drive_routing_arrays`): any value gives the same motor torques; 1 cm keeps the driven radius
N r_m inside the schema's 1 m bound for ratios up to 100."""


def require_one_per_joint(device, what: str) -> None:
    """Refuse ``what`` (a simulator, an export, the compiled device …) on an N+1 device, with a DeviceError (the
    command line's exit 2) naming the limit: the square statics with losses of the core (routing.hpp, losses.hpp)
    and everything built on them need one cable per joint; N+1 tendons have their own core (include/tendyn/tendons.hpp,
    :mod:`tendyn.tendons`) and simulator drive (sim.hpp, DriveKind::Tendons)."""
    if getattr(device, "routing", None) == "n_plus_one":
        raise DeviceError(f"{what}: one cable (or antagonistic pair) per joint needed, K square; this device's "
                          f"{len(device.transmissions)} tendons share its {device.n_joints} joints (N+1). N+1 "
                          "devices are read, checked and shown (`tendyn routing show`), simulated (`tendyn simulate`: "
                          "constant-velocity S2, exciting) and their tendon tensions computed by "
                          "tendyn.tendons.Tendons; the S0 compensator, identification and the exports do not take "
                          "them yet (docs/device-file.md, 'N+1 routings')",
                          file=device.path.name if getattr(device, "path", None) else None, field="device.routing")
