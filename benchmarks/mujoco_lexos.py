"""The L-EXOS twin in MuJoCo with the same physics, for the simulator benchmark (benchmark-only dependency).

The equal-physics model (``lexos_mjcf``):
* the same bodies, masses, inertias and gravity as the twin (its joint frames, tendyn.device.rigid_body);
* one fixed tendon per motor, length = motor angle q_m,i = Σ_j K_ij q_j / r_m,i, with the motor on it
  (gear 1: the control is the motor torque C_m [N·m]) and the rotor inertia as tendon armature
  (M += Gmᵀ J_r Gm, exactly the twin's M_rotor);
* one fixed tendon per cable branch (10 for L-EXOS), length = the branch displacement, velocity
  Ṡ_ib = Σ_{j=b..i} K_ij q̇_j [m/s] (the twin's site Jacobian), with frictionloss [N] and damping ν [N·s/m];
* the reducers as joint frictionloss [N·m] on their driven joints (joint 3 has no reducer, η = 1: no
  constraint; the twin's site for it has an empty box), so 13 friction constraints are active, as in the twin;
* the same step (implicitfast: the damping ν is implicit, as the twin's (M + hD)), the same rate, the same
  commanded motor torques (zero-order hold at the twin's control rate);
* friction constraints made hard at the velocity level: solreffriction = (2h, 1) (the stiffest MuJoCo
  allows) and solimpfriction d = 0.9999, so that a stuck site keeps J v⁺ ≈ 0 as in the twin's
  Moreau–Jean step, and a sliding one carries its bound.

What MuJoCo cannot express: its friction-loss bounds are constants. The twin's bounds depend on the
tension (branch: τ0 + β·|τ_drive|, S0 eqs. 11–12; reducer: (1 − η)|n M_p| driving, (1 − η)/(2η − 1)|n M_p|
back-driven, S0 eq. 10, asymmetric). So the MuJoCo model takes the twin's bounds at the operating point
(their mean over the test run), and the agreement is checked against a twin with the same constant bounds
(``constant_bound_twin``: β = 0, τ0 = those bounds, reducers as constant joint Coulomb sites); the
difference between that twin and the full twin is reported as what MuJoCo's friction leaves out.
"""

from __future__ import annotations

import numpy as np

# Solver settings of the three MuJoCo timings (the model's physics is the same in all three).
DEFAULT_OPTIONS: dict = {}  # MuJoCo's defaults: Newton, 100 iterations, tolerance 1e-8, ls 50, jacobian auto
TUNED_CANDIDATES: list[dict] = [  # expert tuning: the fastest of these that passes the agreement check
    dict(solver=solver, iterations=n, ls_iterations=n, tolerance=1e-6, jacobian="dense")
    for solver in ("PGS", "CG", "Newton") for n in (5, 10)
]
TUNED_DISABLE = ("contact", "equality", "limit", "spring", "midphase", "filterparent", "clampctrl", "sensor", "island")
"""Features the chain does not use, disabled in the tuned and the friction-free timings."""


def branch_sites(n: int) -> list[tuple[int, int]]:
    """(i, b) of every cable branch, in the twin's site order (SimModel.finalize)."""
    return [(i, b) for i in range(n) for b in range(i + 1)]


def lexos_mjcf(device, dt: float, branch_friction: np.ndarray, joint_friction: np.ndarray,
               options: dict | None = None, disable: tuple = (), friction: bool = True) -> str:
    """MJCF of the equal-physics model. branch_friction (n, n) [N] on branch (i, b); joint_friction (n,)
    [N·m]; options: attributes of <option> (solver settings); disable: <flag> names set to "disable";
    friction=False disables every friction-loss constraint (the floor of MuJoCo's fixed cost)."""
    from scipy.spatial.transform import Rotation

    from tendyn.device.rigid_body import joint_frames

    frames = joint_frames(device)
    arr = device.routing_arrays()
    K, r_m, nu = arr["K"], arr["motor_radius"], arr["nu"]
    n = len(frames)
    h = float(dt)
    soft = f'solreffriction="{2 * h:.9g} 1" solimpfriction="0.9999 0.9999 0.001 0.5 2"'
    g = " ".join(f"{x:.17g}" for x in device.kinematics.gravity)
    body_xml = ""
    for k in range(n - 1, -1, -1):
        f = frames[k]
        x, y, z, w = Rotation.from_matrix(f.placement[:3, :3]).as_quat()
        I = f.inertia
        fl = float(joint_friction[k])
        jf = f' frictionloss="{fl:.17g}" {soft}' if fl > 0 else ""
        body_xml = (
            f'<body name="{f.name}" pos="{" ".join(f"{v:.17g}" for v in f.placement[:3, 3])}" '
            f'quat="{w:.17g} {x:.17g} {y:.17g} {z:.17g}">'
            f'<joint name="{f.name}" type="hinge" axis="0 0 1"{jf}/>'
            f'<inertial pos="{" ".join(f"{v:.17g}" for v in f.com)}" mass="{f.mass:.17g}" '
            f'fullinertia="{I[0, 0]:.17g} {I[1, 1]:.17g} {I[2, 2]:.17g} {I[0, 1]:.17g} {I[0, 2]:.17g} {I[1, 2]:.17g}"/>'
            f"{body_xml}</body>")
    tendons, actuators = "", ""
    for i in range(n):
        coefs = "".join(f'<joint joint="{frames[j].name}" coef="{K[i, j] / r_m[i]:.17g}"/>' for j in range(i + 1))
        rotor = device.transmissions[i].motor.rotor_inertia
        tendons += f'<fixed name="motor{i + 1}" armature="{rotor:.17g}">{coefs}</fixed>'
        actuators += f'<motor name="m{i + 1}" tendon="motor{i + 1}" gear="1"/>'
    for i, b in branch_sites(n):
        coefs = "".join(f'<joint joint="{frames[j].name}" coef="{K[i, j]:.17g}"/>' for j in range(b, i + 1))
        fl = float(branch_friction[i, b])
        tendons += (f'<fixed name="branch{i + 1}_{b}" damping="{nu[i, b]:.17g}"'
                    f'{f" frictionloss={chr(34)}{fl:.17g}{chr(34)} {soft}" if fl > 0 else ""}>{coefs}</fixed>')
    opts = {"timestep": f"{h:.17g}", "gravity": g, "integrator": "implicitfast"}
    opts.update({k: str(v) for k, v in (options or {}).items()})
    flags = {name: "disable" for name in disable}
    if not friction:
        flags["frictionloss"] = "disable"
    flag_xml = f'<flag {" ".join(f"{k}={chr(34)}{v}{chr(34)}" for k, v in flags.items())}/>' if flags else ""
    opt_xml = " ".join(f'{k}="{v}"' for k, v in opts.items())
    return (f'<mujoco model="lexos"><option {opt_xml}>{flag_xml}</option>'
            f"<worldbody>{body_xml}</worldbody><tendon>{tendons}</tendon><actuator>{actuators}</actuator></mujoco>")


class MujocoRunner:
    """One compiled MuJoCo model and preallocated rollout buffers for (steps × nu) controls from q0 at rest."""

    def __init__(self, xml: str, q0: np.ndarray, steps: int):
        import mujoco
        from mujoco import rollout

        self._mj, self._rollout = mujoco, rollout
        self.model = mujoco.MjModel.from_xml_string(xml)
        self.data = mujoco.MjData(self.model)
        self.data.qpos[:] = q0
        self.spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        self.state0 = np.zeros(mujoco.mj_stateSize(self.model, self.spec))
        mujoco.mj_getState(self.model, self.data, self.state0, self.spec)
        self.state = np.zeros((1, steps, self.state0.size))
        self.sensordata = np.zeros((1, steps, max(self.model.nsensordata, 0)))
        self.steps = steps

    def run(self, control: np.ndarray) -> np.ndarray:
        """Roll out one run into the preallocated buffers; returns the states (1, steps, nstate)."""
        ctrl = np.ascontiguousarray(np.broadcast_to(control, (1,) + control.shape[-2:]))
        init = np.ascontiguousarray(np.broadcast_to(self.state0, (1, self.state0.size)))
        self._rollout.rollout(self.model, self.data, init, ctrl, state=self.state, sensordata=self.sensordata)
        return self.state

    def qpos(self, states: np.ndarray) -> np.ndarray:
        """Joint positions (…, steps, nq) from rollout states (FULLPHYSICS: time, qpos, qvel, …)."""
        return states[..., 1:1 + self.model.nq]


TRANSMISSION_ARRAYS = ("motor_radius", "K", "driven_radius", "reducer_ratio", "reducer_efficiency", "pretension",
                       "tau0", "nu", "beta")
"""The transmission fields the L-EXOS twin uses (it has no bearings)."""


def with_transmission(model, **changes):
    """The same SimModel with some transmission arrays replaced (public API: a new TransmissionModel, then
    finalize() again)."""
    from tendyn import _core

    arrays = {k: np.array(getattr(model.tendon, k)) for k in TRANSMISSION_ARRAYS}
    arrays.update({k: np.asarray(v, float) for k, v in changes.items()})
    model.tendon = _core.TransmissionModel(arrays)
    model.finalize()
    return model


def constant_bound_twin(compiled, rate_hz: float, branch_friction: np.ndarray, joint_friction: np.ndarray):
    """The twin with MuJoCo's friction: the same SimModel with constant bounds, built with the public API —
    every branch β = 0 and τ0 = branch_friction[i, b] [N]; reducers lossless (η = 1) and their loss a
    constant Coulomb site joint_friction [N·m] on the same joint velocity (the reducer's site Jacobian)."""
    from tendyn.sim.model import sim_model

    m = sim_model(compiled, rate_hz=rate_hz)
    m.coulomb_joint = np.asarray(joint_friction, float)
    return with_transmission(m, tau0=np.tril(np.asarray(branch_friction, float)), beta=np.zeros((m.na, m.na)),
                             reducer_efficiency=np.ones(m.na))


def operating_point_bounds(model, q0: np.ndarray, ff: np.ndarray, stats: dict | None = None):
    """The twin's friction bounds averaged over a run (its operating point): branch (n, n) [N] and reducer
    (n,) [N·m] (the mean of the driving and back-driven bounds: MuJoCo's box is symmetric). Steps the twin
    one step at a time (setup, not timed) and reads the tensions friction_bounds uses at each step; `stats`,
    if given, receives the twin's friction-solver iterations per step (mean, max, share of steps at the cap)."""
    from tendyn import _core

    n = model.na
    d = _core.SimData(model)
    d.reset(q0, 1)
    tr = model.tendon
    tau0, beta, eta = np.array(tr.tau0), np.array(tr.beta), np.array(tr.reducer_efficiency)
    gen = np.array(tr.reducer_ratio) * np.array(tr.driven_radius)
    branch, joint = np.zeros((n, n)), np.zeros(n)
    z = np.zeros(n)
    back = np.where(eta > 0.5, (1 - eta) / np.maximum(2 * eta - 1, 1e-300), np.inf)
    iterations, finished = np.empty(ff.shape[0]), np.empty(ff.shape[0])
    for s in range(ff.shape[0]):
        T, Tm = np.array(d.tension), np.array(d.tension_motor)
        up = np.column_stack([Tm, T[:, :-1]])  # tension on the motor side of branch b
        branch += np.tril(tau0 + beta * np.maximum(np.abs(up), np.abs(T)))
        out = np.abs(gen * np.diag(T))
        joint += 0.5 * ((1 - eta) * out + back * out)
        _core.step(model, d, z, z, ff[s], z)
        iterations[s], finished[s] = d.pgs_iterations, d.pgs_finished
    if stats is not None:
        stats.update(mean=float(iterations.mean()), max=int(iterations.max()),
                     share_at_cap=float(np.mean(iterations >= model.pgs_max_iterations)),
                     share_exact_finish=float(finished.mean()))
    return branch / ff.shape[0], joint / ff.shape[0]
