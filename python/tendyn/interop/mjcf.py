"""A device as a MuJoCo model (MJCF): bodies and joints from its kinematics, the coupling as fixed tendons.

What the file holds (``tendyn export mjcf DEVICE``; docs/cli.md):

* one body per joint of the rigid-body tree (``tendyn.device.rigid_body.joint_frames``: the same frames, masses,
  COMs and inertias as tendyn's own models), hinge or slide joints on the frame's axis, ranges from the limits;
* one fixed tendon per motor, named after it, whose length is the motor angle q_m,i = Σ_j G_ij q_j
  (:func:`tendyn.coupling.coupling`, the file's motor order), with the rotor inertia as tendon ``armature``
  (M += Gᵀ J_r G) and a ``<motor>`` actuator on it (gear 1: the control is the motor torque [N·m]);
* the losses MuJoCo can express: for cable routing one fixed tendon per cable branch with the branch's velocity
  as its length rate (the coefficients of ``Transmission.branch_velocities``), ``frictionloss`` = τ0 [N] and
  ``damping`` = ν [N·s/m] (S0 eq. 12), the friction as stiff as MuJoCo accepts (:func:`_loss_attrs`); for geared motors and capstan drives the motor-side Coulomb and viscous
  friction on the motor tendon;
* a comment naming every loss term of the device MuJoCo cannot express (MuJoCo's friction-loss bound is a
  constant: tension-proportional β, bearings and reducer efficiencies depend on the load), and other terms left out;
* closed loops (``[[kinematics.constraints]]``) as tendon equalities q_passive − Σ L q_active = c.
"""

from __future__ import annotations

from xml.sax.saxutils import quoteattr

import numpy as np


FRICTION_SOLIMP = "0.99 0.999 0.001"
"""MuJoCo ``solimpfriction`` of an exported friction loss: impedance near 1, so the dry friction holds."""


def _loss_attrs(frictionloss: float, damping: float, timestep: float) -> str:
    """The MJCF attributes of a tendon's loss terms [N or N·m; N·s/m or N·m·s/rad]. A friction loss is made as
    stiff as MuJoCo accepts (``solreffriction`` time constant 2·timestep, its lower bound; critical damping):
    with MuJoCo's default soft friction a generated 3-joint device crept 0.8 % of its motion away from the
    twin's Coulomb friction in 0.3 s, with these 1.3e-6 rad (tests/python/test_coupling_export.py)."""
    out = ""
    if frictionloss > 0:
        out += (f' frictionloss="{_f(frictionloss)}" solreffriction="{_f(2 * timestep)} 1"'
                f' solimpfriction="{FRICTION_SOLIMP}"')
    if damping > 0:
        out += f' damping="{_f(damping)}"'
    return out


def _f(x: float) -> str:
    return f"{float(x):.17g}"


def _v(xs) -> str:
    return " ".join(_f(x) for x in np.ravel(xs))


def _quat(R: np.ndarray) -> str:
    """MuJoCo quaternion (w x y z) of a rotation matrix."""
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(np.asarray(R, float)).as_quat()
    return _v((w, x, y, z))


def _name(text: str) -> str:
    return quoteattr(str(text))


def branch_jacobian(transmission) -> np.ndarray:
    """(m, n_branches, n) J with Ṡ[i, b] = Σ_j J[i, b, j] q̇_j [m/rad], from the core's branch velocities (linear
    in q̇: one call per unit joint velocity)."""
    n = np.shape(transmission.K)[1]          # joints (columns of K), whatever the number of cables
    cols = [np.array(transmission.branch_velocities(np.eye(n)[j])) for j in range(n)]
    return np.stack(cols, axis=-1)


def not_expressible(device) -> list[str]:
    """The device's loss and model terms a MuJoCo model cannot carry (names as in the device file)."""
    out = []
    if device.transmissions:
        arr = device.routing_arrays()
        if np.any(arr["beta"] > 0):
            out.append("transmissions.friction.beta (tension-proportional branch loss, S0 eq. 11: MuJoCo's "
                       "frictionloss is a constant bound)")
        if np.any(arr["bearing_count"] > 0):
            out.append("transmissions.bearings (radial-load bearing friction, S0 eqs. 7-8)")
        if np.any(arr["reducer_efficiency"] < 1):
            out.append("transmissions.reducer_efficiency (load-dependent, direction-dependent reducer loss, "
                       "S0 eq. 10)")
        if np.any(arr["pretension"] > 0):
            out.append("transmissions.pretension (it only loads the bearings and the beta losses)")
        out.append("static friction above Coulomb (tau0 is the bound at break-away and while sliding alike)")
    if device.drives:
        out.append("drives.stiffness_motor, drives.damping_motor, drives.servo_stiffness_motor (the capstan "
                   "cable is rigid here: the coupling is its ratio)")
        if any(d.offset_joint for d in device.drives):
            out.append("drives.offset_joint (a constant joint torque)")
    if device.actuators and any(a.encoder_offset for a in device.actuators):
        out.append("actuators.encoder_offset (a sensor zero, not physics: MuJoCo's joint angles are the "
                   "device's joint angles)")
    return out


def to_mjcf(device, *, timestep: float = 1e-3, integrator: str = "implicitfast", limits: bool = True,
            losses: bool = True) -> str:
    """The MJCF text of a serial device (any actuation: ``[[transmissions]]``, ``[[drives]]``, ``[[actuators]]``).

    Parameters
    ----------
    timestep : MuJoCo step [s]
    integrator : MuJoCo integrator ("Euler", "implicitfast", "RK4", …)
    limits : joint ranges from the device's limits (False: unlimited joints)
    losses : False leaves every friction and damping term out (the lossless coupling alone)
    """
    from tendyn.coupling import coupling
    from tendyn.device import compile_device
    from tendyn.device.rigid_body import tree_joint_numbers

    cd = compile_device(device)
    c = coupling(device)
    frames = cd.joint_frames
    numbers = tree_joint_numbers(device)
    specs = device.kinematics.joints
    L, offset = cd.active_map
    active = list(cd.active_joints)

    # ---- bodies: nested by parent (0 = world) ----
    children: dict[int, list[int]] = {}
    for k, f in enumerate(frames):
        children.setdefault(int(f.parent), []).append(k + 1)

    def body(idx: int, depth: int) -> str:
        f = frames[idx - 1]
        js = specs[numbers[idx - 1] - 1]
        pad = "  " * depth
        rng = ""
        if limits and js.lower is not None and js.upper is not None:
            rng = f' range="{_f(js.lower)} {_f(js.upper)}"'
        kind = "slide" if f.prismatic else "hinge"
        I = np.asarray(f.inertia, float)
        inner = (f'{pad}  <joint name={_name(f.name)} type="{kind}" axis="{_v(f.axis)}"{rng}/>\n'
                 f'{pad}  <inertial pos="{_v(f.com)}" mass="{_f(f.mass)}" fullinertia="{_f(I[0, 0])} {_f(I[1, 1])} '
                 f'{_f(I[2, 2])} {_f(I[0, 1])} {_f(I[0, 2])} {_f(I[1, 2])}"/>\n')
        inner += "".join(body(ch, depth + 1) for ch in children.get(idx, []))
        return (f'{pad}<body name={_name(f.name)} pos="{_v(f.placement[:3, 3])}" quat="{_quat(f.placement[:3, :3])}">\n'
                f"{inner}{pad}</body>\n")

    world = "".join(body(ch, 2) for ch in children.get(0, []))

    # ---- tendons: one per motor (the coupling), one per lossy cable branch ----
    joint_name = [f.name for f in frames]
    if device.actuators:
        rotor = [a.rotor_inertia for a in device.actuators]
        motor_loss = [(a.coulomb_motor, a.viscous_motor) for a in device.actuators]
        peak = [None] * len(rotor)
    elif device.drives:
        rotor = [d.motor.rotor_inertia for d in device.drives]
        motor_loss = [(d.coulomb_motor, d.viscous_motor) for d in device.drives]
        peak = [d.motor.peak_torque for d in device.drives]
    else:
        rotor = [t.motor.rotor_inertia for t in device.transmissions]
        motor_loss = [(0.0, 0.0)] * len(rotor)
        peak = [t.motor.peak_torque for t in device.transmissions]
    tendons, actuators = [], []
    for i, name in enumerate(c.motors):
        coefs = "".join(f'<joint joint={_name(joint_name[active[j]])} coef="{_f(g)}"/>'
                        for j, g in enumerate(c.G[i]) if g != 0.0)
        fl, dmp = motor_loss[i] if losses else (0.0, 0.0)
        tendons.append(f'    <fixed name={_name(name)} armature="{_f(rotor[i])}"{_loss_attrs(fl, dmp, timestep)}>'
                       f'{coefs}</fixed>')
        rng = f' ctrlrange="{_f(-peak[i])} {_f(peak[i])}"' if peak[i] else ""
        actuators.append(f'    <motor name={_name(name)} tendon={_name(name)} gear="1"{rng}/>')
    if device.transmissions and losses:
        tr = cd.transmission
        J = branch_jacobian(tr)
        arr = device.routing_arrays()
        tree_of_file = {num: k for k, num in enumerate(numbers)}
        for i, t in enumerate(device.transmissions):
            for b in range(J.shape[1]):
                tau0, nu = float(arr["tau0"][i, b]), float(arr["nu"][i, b])
                if tau0 <= 0 and nu <= 0:
                    continue
                coefs = "".join(f'<joint joint={_name(joint_name[tree_of_file[j + 1]])} coef="{_f(J[i, b, j])}"/>'
                                for j in range(J.shape[2]) if J[i, b, j] != 0.0 and (j + 1) in tree_of_file)
                if not coefs:
                    continue
                tendons.append(f'    <fixed name={_name(f"{t.name}_branch{b}")}{_loss_attrs(tau0, nu, timestep)}>'
                               f'{coefs}</fixed>')

    # ---- closed loops: q_tree = L q_active + c for the passive joints ----
    equalities = []
    for k in range(len(frames)):
        if k in active:
            continue
        coefs = f'<joint joint={_name(joint_name[k])} coef="1"/>' + "".join(
            f'<joint joint={_name(joint_name[active[j]])} coef="{_f(-L[k, j])}"/>'
            for j in range(L.shape[1]) if L[k, j] != 0.0)
        tendons.append(f'    <fixed name={_name(f"loop_{joint_name[k]}")}>{coefs}</fixed>')
        equalities.append(f'    <tendon tendon1={_name(f"loop_{joint_name[k]}")} polycoef="{_f(offset[k])} 0 0 0 0"/>')

    missing = not_expressible(device) if losses else ["every loss term (exported with losses=False)"]
    comment = ("  <!-- Generated by tendyn from device " + _xml_comment(device.name) + ". SI units. Motor tendon i = "
               "motor i of the device file (length = motor angle q_m = G q, armature = rotor inertia); its actuator's "
               "control is the motor torque [N m].\n       Not expressible in MuJoCo, left out: "
               + ("; ".join(_xml_comment(m) for m in missing) if missing else "nothing") + ". -->\n")
    g = _v(device.kinematics.gravity)
    xml = [f"<mujoco model={_name(device.name)}>", comment.rstrip("\n"),
           '  <compiler angle="radian" autolimits="true" boundmass="1e-9" boundinertia="1e-12"/>',
           f'  <option timestep="{_f(timestep)}" gravity="{g}" integrator="{integrator}"/>',
           "  <worldbody>", world.rstrip("\n"), "  </worldbody>",
           "  <tendon>", *tendons, "  </tendon>", "  <actuator>", *actuators, "  </actuator>"]
    if equalities:
        xml += ["  <equality>", *equalities, "  </equality>"]
    xml.append("</mujoco>")
    return "\n".join(line for line in xml if line) + "\n"


def _xml_comment(text: str) -> str:
    """Text safe inside an XML comment (no ``--``)."""
    return str(text).replace("--", "- -")
