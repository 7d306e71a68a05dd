"""A device's coupling as ros2_control transmissions (URDF ``<ros2_control>`` with ``<transmission>`` blocks).

ros2_control's ``transmission_interface`` has three fixed couplings (facts from its documentation):

* ``SimpleTransmission`` (1 actuator, 1 joint): x_a = n (x_j − x_off), τ_j = n τ_a;
* ``DifferentialTransmission`` (2 and 2): x_a1 = n_a1 (n_j1 x_j1 + n_j2 x_j2), x_a2 = n_a2 (n_j1 x_j1 − n_j2 x_j2),
  efforts τ_j1 = n_j1 (n_a1 τ_a1 + n_a2 τ_a2), τ_j2 = n_j2 (n_a1 τ_a1 − n_a2 τ_a2) — the transpose of the
  position map, as virtual work wants;
* ``FourBarLinkageTransmission`` (2 and 2): x_a1 = n_j1 n_a1 x_j1, x_a2 = n_a2 (x_j1 + n_j2 x_j2); its effort map
  (τ_j1 = n_j1 n_a1 τ_a1, τ_j2 = n_j2 (n_a2 τ_a2 − n_j1 n_a1 τ_a1)) is *not* the transpose of its position map,
  so a torque-controlled joint pair would get wrong torques: it is exported only with ``four_bar=True`` and a
  comment saying so.

The device's G (:func:`tendyn.coupling.coupling`, q_motor = G q) is split into its connected blocks (motors and
joints linked by nonzero entries); each block must be one of the above, else :class:`CouplingNotExpressible`
names the block. Offsets: an ``[[actuators]]`` encoder offset is the joint ``<offset>``.
"""

from __future__ import annotations

from xml.sax.saxutils import quoteattr

import numpy as np

TOL = 1e-9
"""Relative tolerance of the block-shape tests."""


class CouplingNotExpressible(ValueError):
    """The coupling has a block no ros2_control transmission type expresses (the message names it)."""


def blocks(G: np.ndarray) -> list[tuple[list[int], list[int]]]:
    """Connected (motors, joints) blocks of G (0-based), in the order of their first motor."""
    m, n = G.shape
    nz = np.abs(G) > TOL * max(1.0, float(np.abs(G).max(initial=0.0)))
    seen_m, out = set(), []
    for start in range(m):
        if start in seen_m:
            continue
        motors, joints, stack = {start}, set(), [("m", start)]
        while stack:
            kind, k = stack.pop()
            if kind == "m":
                for j in np.flatnonzero(nz[k]):
                    if j not in joints:
                        joints.add(int(j))
                        stack.append(("j", int(j)))
            else:
                for i in np.flatnonzero(nz[:, k]):
                    if i not in motors:
                        motors.add(int(i))
                        stack.append(("m", int(i)))
        seen_m |= motors
        out.append((sorted(motors), sorted(joints)))
    return out


def _close(a: float, b: float) -> bool:
    return abs(a - b) <= 1e-9 * max(1.0, abs(a), abs(b))


def fit_differential(B: np.ndarray):
    """(actuator_reduction, joint_reduction) with B = [[a1 j1, a1 j2], [a2 j1, −a2 j2]], or None."""
    if np.any(np.abs(B) <= TOL):
        return None
    j1 = 1.0
    a1, a2 = B[0, 0] / j1, B[1, 0] / j1
    j2 = B[0, 1] / a1
    if not _close(-a2 * j2, B[1, 1]):
        return None
    return (a1, a2), (j1, j2)


def fit_four_bar(B: np.ndarray):
    """(actuator_reduction, joint_reduction) with B = [[j1 a1, 0], [a2, a2 j2]], or None."""
    if abs(B[0, 1]) > TOL or abs(B[0, 0]) <= TOL or abs(B[1, 0]) <= TOL or abs(B[1, 1]) <= TOL:
        return None
    a1, j1 = B[0, 0], 1.0
    a2 = B[1, 0]
    return (a1, a2), (j1, B[1, 1] / a2)


def differential_matrix(ar, jr) -> np.ndarray:
    """G of a DifferentialTransmission (position map, as documented by ros2_control)."""
    return np.array([[ar[0] * jr[0], ar[0] * jr[1]], [ar[1] * jr[0], -ar[1] * jr[1]]])


def four_bar_matrix(ar, jr) -> np.ndarray:
    """G of a FourBarLinkageTransmission (position map, as documented by ros2_control)."""
    return np.array([[jr[0] * ar[0], 0.0], [ar[1], ar[1] * jr[1]]])


def plan(device, *, four_bar: bool = False) -> list[dict]:
    """One transmission per block of the device's G: ``{"type", "motors", "joints", "actuator_reduction",
    "joint_reduction", "joint_offset"}`` (names, reductions). Raises :class:`CouplingNotExpressible`."""
    from tendyn.coupling import coupling

    c = coupling(device)
    G = c.G
    offsets = np.zeros(c.n_joints)
    if device.actuators:
        off = {a.joint: a.encoder_offset for a in device.actuators}
        offsets = np.array([off.get(num, 0.0) for num in c.joint_numbers])
    out = []
    for motors, joints in blocks(G):
        names_m = [c.motors[i] for i in motors]
        names_j = [c.joints[j] for j in joints]
        where = (f"motors {', '.join(names_m)} and joints {', '.join(names_j)} "
                 f"({len(motors)}×{len(joints)} block of G)")
        if len(motors) != len(joints):
            raise CouplingNotExpressible(f"{where}: ros2_control transmissions pair as many actuators as joints")
        if len(motors) == 1:
            out.append({"type": "transmission_interface/SimpleTransmission", "motors": names_m, "joints": names_j,
                        "actuator_reduction": [1.0], "joint_reduction": [float(G[motors[0], joints[0]])],
                        "joint_offset": [float(offsets[joints[0]])]})
            continue
        if len(motors) > 2:
            raise CouplingNotExpressible(f"{where}: ros2_control couples at most two joints (simple, differential, "
                                         "four-bar transmissions); this block needs a custom transmission plugin")
        B = G[np.ix_(motors, joints)]
        found = None
        for jo in (joints, joints[::-1]):             # the roles may be either way round
            for mo in (motors, motors[::-1]):
                Bm = G[np.ix_(mo, jo)]
                fit = fit_differential(Bm)
                if fit:
                    found = ("transmission_interface/DifferentialTransmission", mo, jo, fit)
                    break
                fit = fit_four_bar(Bm) if four_bar else None
                if fit:
                    found = ("transmission_interface/FourBarLinkageTransmission", mo, jo, fit)
                    break
            if found:
                break
        if not found:
            lower = (abs(B[0, 1]) <= TOL) != (abs(B[1, 0]) <= TOL)
            hint = ("; it is four-bar shaped: pass --four-bar to export it (ros2_control's four-bar effort map is "
                    "not the transpose of its position map)" if lower and not four_bar else "")
            raise CouplingNotExpressible(f"{where}: {np.round(B, 6).tolist()} is neither a differential "
                                         f"[[a1 j1, a1 j2], [a2 j1, -a2 j2]] nor a simple pair{hint}")
        kind, mo, jo, (ar, jr) = found
        out.append({"type": kind, "motors": [c.motors[i] for i in mo], "joints": [c.joints[j] for j in jo],
                    "actuator_reduction": [float(x) for x in ar], "joint_reduction": [float(x) for x in jr],
                    "joint_offset": [float(offsets[j]) for j in jo]})
    return out


def to_ros2_control(device, *, four_bar: bool = False, plugin: str = "mock_components/GenericSystem") -> str:
    """The URDF fragment (a ``<robot>`` with one ``<ros2_control>`` system) of the device's coupling.

    Joints get effort command and position/velocity state interfaces; ``plugin`` is the hardware plugin to fill in.
    """
    trans = plan(device, four_bar=four_bar)
    q = quoteattr
    lines = [f"<robot name={q(device.name)}>",
             f"  <!-- Generated by tendyn from device {device.name.replace('--', '- -')}: motor-from-joint coupling "
             "q_motor = G q as ros2_control transmissions (SI units). Loss terms are not part of a ros2_control "
             "transmission. -->",
             f"  <ros2_control name={q(device.name)} type=\"system\">",
             f"    <hardware><plugin>{plugin}</plugin></hardware>"]
    for t in trans:
        for j in t["joints"]:
            lines += [f"    <joint name={q(j)}>", '      <command_interface name="effort"/>',
                      '      <state_interface name="position"/>', '      <state_interface name="velocity"/>',
                      "    </joint>"]
    for k, t in enumerate(trans, start=1):
        lines.append(f"    <transmission name={q('transmission' + str(k))}>")
        if t["type"].endswith("FourBarLinkageTransmission"):
            lines.append("      <!-- ros2_control's four-bar effort map is not the transpose of its position map: "
                         "effort commands through it are not power-consistent with this coupling. -->")
        lines.append(f"      <plugin>{t['type']}</plugin>")
        two = len(t["motors"]) == 2
        for r, (mname, red) in enumerate(zip(t["motors"], t["actuator_reduction"]), start=1):
            role = f' role="actuator{r}"' if two else ""
            lines += [f"      <actuator name={q(mname)}{role}>",
                      f"        <mechanical_reduction>{red:.17g}</mechanical_reduction>", "      </actuator>"]
        for r, (jname, red, off) in enumerate(zip(t["joints"], t["joint_reduction"], t["joint_offset"]), start=1):
            role = f' role="joint{r}"' if two else ""
            lines += [f"      <joint name={q(jname)}{role}>", f"        <offset>{off:.17g}</offset>",
                      f"        <mechanical_reduction>{red:.17g}</mechanical_reduction>", "      </joint>"]
        lines.append("    </transmission>")
    lines += ["  </ros2_control>", "</robot>"]
    return "\n".join(lines) + "\n"


def coupling_of(plan_rows: list[dict], motors: list[str], joints: list[str]) -> np.ndarray:
    """G rebuilt from transmission rows (the round-trip check of the tests): simple q_a = a·j·q_j, differential and
    four-bar as documented."""
    G = np.zeros((len(motors), len(joints)))
    for t in plan_rows:
        mi = [motors.index(m) for m in t["motors"]]
        ji = [joints.index(j) for j in t["joints"]]
        ar, jr = t["actuator_reduction"], t["joint_reduction"]
        if t["type"].endswith("SimpleTransmission"):
            B = np.array([[ar[0] * jr[0]]])
        elif t["type"].endswith("DifferentialTransmission"):
            B = differential_matrix(ar, jr)
        else:
            B = four_bar_matrix(ar, jr)
        G[np.ix_(mi, ji)] = B
    return G
