"""The L-EXOS chain in MuJoCo, for the simulator benchmark's baseline (benchmark-only dependency).

Same bodies, masses, inertias and gravity as the twin; the cable coupling as fixed tendons
(motor angle = Σ_j K_ij q_j / r_m^i), motors on the tendons, rotor inertia as tendon armature,
Coulomb friction as tendon and joint frictionloss (MuJoCo's friction-loss constraints).
"""

import numpy as np


def lexos_mjcf(device, dt: float) -> str:
    from scipy.spatial.transform import Rotation

    from tendyn.device.rigid_body import joint_frames

    frames = joint_frames(device)
    arr = device.routing_arrays()
    K, r_m = arr["K"], arr["motor_radius"]
    g = " ".join(f"{x:.6g}" for x in device.kinematics.gravity)
    body_xml = ""
    for f in reversed(frames):
        x, y, z, w = Rotation.from_matrix(f.placement[:3, :3]).as_quat()
        I = f.inertia
        inner = body_xml
        body_xml = (
            f'<body name="{f.name}" pos="{" ".join(f"{v:.9g}" for v in f.placement[:3, 3])}" quat="{w:.9g} {x:.9g} {y:.9g} {z:.9g}">'
            f'<joint name="{f.name}" type="hinge" axis="0 0 1" frictionloss="{K[frames.index(f), frames.index(f)] * 1.0:.6g}"/>'
            f'<inertial pos="{" ".join(f"{v:.9g}" for v in f.com)}" mass="{f.mass:.9g}" '
            f'fullinertia="{I[0, 0]:.9g} {I[1, 1]:.9g} {I[2, 2]:.9g} {I[0, 1]:.9g} {I[0, 2]:.9g} {I[1, 2]:.9g}"/>'
            f"{inner}</body>")
    tendons, actuators = "", ""
    n = len(frames)
    for i in range(n):
        coefs = "".join(f'<joint joint="{frames[j].name}" coef="{K[i, j] / r_m[i]:.9g}"/>' for j in range(i + 1))
        rotor = device.transmissions[i].motor.rotor_inertia
        fl = (i + 1) * 1.0 * r_m[i]  # τ0 = 1 N on each branch, seen at the motor
        tendons += f'<fixed name="t{i + 1}" armature="{rotor:.6g}" frictionloss="{fl:.6g}">{coefs}</fixed>'
        actuators += f'<motor name="m{i + 1}" tendon="t{i + 1}" gear="1"/>'
    return (f'<mujoco model="lexos"><option timestep="{dt}" gravity="{g}"/>'
            f"<worldbody>{body_xml}</worldbody><tendon>{tendons}</tendon><actuator>{actuators}</actuator></mujoco>")


def rollout_seconds(device, dt: float, control: np.ndarray, q0: np.ndarray, repeats: int = 3) -> float:
    """Best wall time [s] of mujoco.rollout over the given controls (nstep × nu) from q0 at rest."""
    import time

    import mujoco
    from mujoco import rollout

    model = mujoco.MjModel.from_xml_string(lexos_mjcf(device, dt))
    data = mujoco.MjData(model)
    data.qpos[:] = q0
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.zeros(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state, spec)
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        rollout.rollout(model, data, state[None, :], control[None, :, :])
        best = min(best, time.perf_counter() - t0)
    return best
