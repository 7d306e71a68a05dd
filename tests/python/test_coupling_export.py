"""One coupling for every device kind, `routing show` / `routing import`, and the exports to MuJoCo and ros2_control.

Oracles are written here from the documented formulas, not taken from the code under test: G of a hand-written
[[actuators]] file, R_m⁻¹K from the routing arrays against the core's matrices, ros2_control's published
transmission equations, an independent RK4 integration (Pinocchio) against MuJoCo's RK4 on the exported model.
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from tendyn.cli import main
from tendyn.coupling import coupling
from tendyn.device import load_device
from tendyn.devices import bundled
from tendyn.devices.generate import cable_device_toml, write_cable_device


def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def actuator_device(folder: Path, G: np.ndarray, *, name: str = "geared", rotor: float = 3e-5, seed: int = 1) -> Path:
    """A generated n-joint chain (kinematics of tendyn.devices.generate) with [[actuators]] written by hand so that
    q_motor = G q, motor i = row i (each row names the joint of its first nonzero entry not yet taken)."""
    n = G.shape[0]
    text = cable_device_toml(n, name=name, seed=seed)
    text = text[:text.index("[[transmissions]]")]
    taken = set()
    for i, row in enumerate(G):
        j = next(k for k in range(n) if row[k] != 0 and k not in taken)
        taken.add(j)
        coup = ", ".join(f'"{k + 1}" = {float(row[k] / row[j])!r}' for k in range(n) if k != j and row[k] != 0)
        text += (f'[[actuators]]\nname = "m{i + 1}"\njoint = {j + 1}\nratio = {float(row[j])!r}\nrotor_inertia = {rotor!r}\n'
                 + (f"coupling = {{ {coup} }}\n" if coup else ""))
    path = folder / f"{name}.toml"
    path.write_text(text)
    return path


ZERO_DIAGONAL = np.array([[0.0, 12.0, -12.0], [20.0, 0.0, 0.0], [0.0, 15.0, 15.0]])
"""A surgical-wrist-like coupling with a zero diagonal: motor 1 drives the jaw difference, motor 2 joint 1."""


# ---- one coupling, every kind ----------------------------------------------------------------------------

def test_zero_diagonal_coupling_keeps_the_files_motor_order(tmp_path):
    """Motor i is the i-th [[actuators]] entry: a zero-diagonal coupling is not renumbered by the joint driven."""
    dev = load_device(actuator_device(tmp_path, ZERO_DIAGONAL))
    assert [a.name for a in dev.actuators] == ["m1", "m2", "m3"]
    np.testing.assert_array_equal(dev.motor_joint_matrix(), ZERO_DIAGONAL)
    c = coupling(dev)
    np.testing.assert_array_equal(c.G, ZERO_DIAGONAL)
    assert c.motor_joints() == [[2, 3], [1], [2, 3]]


def test_coupling_of_a_routing_is_the_cores_matrices(tmp_path):
    """[[transmissions]]: G = R_m⁻¹K from the routing arrays, and the four maps equal the C++ core's."""
    from tendyn.transmission import Transmission

    for dev in (load_device(bundled("lexos")), load_device(write_cable_device(tmp_path, 5, planar=False, seed=3))):
        c = coupling(dev)
        arr = dev.routing_arrays()
        np.testing.assert_allclose(c.G, arr["K"] / arr["motor_radius"][:, None], rtol=1e-15)
        core = Transmission.from_device(dev).matrices()
        for key, M in c.matrices().items():
            np.testing.assert_allclose(M, core[key], rtol=1e-12, atol=1e-12, err_msg=key)
        assert c.actuation == "transmissions" and c.motors == tuple(t.name for t in dev.transmissions)


def test_coupling_of_geared_and_capstan_devices():
    """tx40 ([[actuators]]): G = diag(32, 32, 45, −48, 45, 32) with q_m6 = 32 (q6 + q5); cea_branch ([[drives]])."""
    c = coupling(load_device(bundled("tx40")))
    G = np.diag([32.0, 32.0, 45.0, -48.0, 45.0, 32.0])
    G[5, 4] = 32.0
    np.testing.assert_array_equal(c.G, G)
    M = c.matrices()
    np.testing.assert_allclose(M["joint_from_motor_position"] @ G, np.eye(6), atol=1e-14)
    np.testing.assert_allclose(M["motor_from_joint_torque"], np.linalg.inv(G).T, atol=1e-15)
    cea = load_device(bundled("cea_branch"))
    c = coupling(cea)
    assert c.actuation == "drives"
    np.testing.assert_allclose(c.G, np.diag([d.ratio for d in cea.drives]))


@pytest.mark.parametrize("device", ["tx40", "lexos", "cea_branch", "generated", "zero_diagonal"])
def test_routing_show_prints_the_four_matrices_for_every_device(capsys, tmp_path, device):
    arg = {"generated": lambda: write_cable_device(tmp_path, 3, seed=5),
           "zero_diagonal": lambda: actuator_device(tmp_path, ZERO_DIAGONAL)}.get(device, lambda: device)()
    code, out, _ = run_cli(capsys, "routing", "show", arg, "--json")
    assert code == 0
    doc = json.loads(out)
    G = np.asarray(doc["motor_from_joint_position"])
    assert G.shape[0] == len(doc["motors"]) > 0
    np.testing.assert_allclose(np.asarray(doc["joint_from_motor_position"]) @ G, np.eye(G.shape[1]), atol=1e-10)
    np.testing.assert_allclose(np.asarray(doc["joint_from_motor_torque"]), G.T)
    if device == "zero_diagonal":
        np.testing.assert_array_equal(G, ZERO_DIAGONAL)
        assert doc["motors"] == ["m1", "m2", "m3"]
    code, text, _ = run_cli(capsys, "routing", "show", arg)
    assert code == 0 and "0 capstan drives" not in text
    for key in doc["units"]:
        if key not in ("K", "R_m"):
            assert key in text
    if device == "tx40":
        assert "6 geared motors" in text and "coupling +1·q5" in text


# ---- routing import ----------------------------------------------------------------------------------------

def _dvrk(G):
    inv = np.linalg.inv(G)
    return ("/* dVRK-style tool file */\n{\n  // values from a user guide\n  \"coupling\" : {\n"
            f"    \"ActuatorToJointPosition\" : {json.dumps(inv.tolist())},\n"
            f"    \"JointToActuatorPosition\" : {json.dumps(G.tolist())},\n"
            f"    \"ActuatorToJointEffort\" : {json.dumps(G.T.tolist())},\n"
            f"    \"JointToActuatorEffort\" : {json.dumps(inv.T.tolist())}\n  }}\n}}\n")


def _libbarrett(G):
    rows = ",\n\t\t".join("(" + ", ".join(repr(float(v)) for v in r) + ")" for r in G)
    return f"# libbarrett-style\nwam:\n{{\n\tlow_level:\n\t{{\n\t\thome = (0, 0, 0);\n\t\tj2mp = ({rows});\n\t}};\n}};\n"


def _icub(G, gear):
    M2J = np.linalg.inv(np.diag(1 / np.asarray(gear)) @ G)      # q_j = M2J (q_rotor / gearbox)
    vals = "\n".join(" ".join(repr(float(v)) for v in r) for r in M2J)
    return ('<?xml version="1.0" encoding="UTF-8" ?>\n<!DOCTYPE params PUBLIC "-//YARP//DTD" "x.dtd">\n'
            '<params robot="r" build="1"><group name="GENERAL">'
            f'<param name="Gearbox_M2J"> {" ".join(map(str, gear))} </param></group>'
            f'<group name="COUPLINGS"><param name="matrixM2J">\n{vals}\n</param>'
            '<param name="matrixJ2M"> 1 0 0 0 1 0 0 0 1 </param></group></params>\n')


@pytest.mark.parametrize("fmt", ["dvrk", "libbarrett", "icub", "plain"])
@pytest.mark.parametrize("G", [ZERO_DIAGONAL, np.array([[-42.0, 0, 0], [0, 28.25, -16.8155], [0, -28.25, -16.8155]])],
                         ids=["zero_diagonal", "shoulder_differential"])
def test_routing_import_each_format(capsys, tmp_path, fmt, G):
    src = write_cable_device(tmp_path, 3, seed=7)
    name, text = {"dvrk": ("tool.json", _dvrk(G)), "libbarrett": ("wam.conf", _libbarrett(G)),
                  "icub": ("arm-mec.xml", _icub(G, [100.0, -100.0, 50.0])),
                  "plain": ("g.txt", "# G\n" + "\n".join(" ".join(repr(float(v)) for v in r) for r in G))}[fmt]
    (tmp_path / name).write_text(text)
    out = tmp_path / "sub" / "imported.toml"
    out.parent.mkdir()
    code, so, err = run_cli(capsys, "routing", "import", src, tmp_path / name, "--out", out, "--json")
    assert code == 0, err
    assert json.loads(so)["format"] == fmt
    dev = load_device(out)
    assert not dev.transmissions and len(dev.actuators) == 3
    np.testing.assert_allclose(dev.motor_joint_matrix(), G, rtol=1e-9, atol=1e-12)
    assert [a.name for a in dev.actuators] == ["motor1", "motor2", "motor3"]


def test_routing_import_pads_and_refusals(capsys, tmp_path):
    src = write_cable_device(tmp_path, 2, seed=2)
    padded = np.eye(7)
    padded[:2, :2] = [[0.0, 3.0], [2.0, 1.0]]
    (tmp_path / "psm.json").write_text(json.dumps({"coupling": {"actuator_to_joint_position": np.linalg.inv(padded).tolist()}}))
    code, _, err = run_cli(capsys, "routing", "import", src, tmp_path / "psm.json", "--out", tmp_path / "a.toml")
    assert code == 0, err
    np.testing.assert_allclose(load_device(tmp_path / "a.toml").motor_joint_matrix(), padded[:2, :2], atol=1e-12)
    bad = {"coupling": {"ActuatorToJointPosition": [[1, 0], [0, 1]], "JointToActuatorPosition": [[2, 0], [0, 1]]}}
    (tmp_path / "bad.json").write_text(json.dumps(bad))
    code, _, err = run_cli(capsys, "routing", "import", src, tmp_path / "bad.json", "--out", tmp_path / "b.toml")
    assert code == 2 and "disagree" in err and "\n" not in err.strip() and not (tmp_path / "b.toml").exists()
    (tmp_path / "sing.txt").write_text("1 2\n2 4\n")
    code, _, err = run_cli(capsys, "routing", "import", src, tmp_path / "sing.txt", "--out", tmp_path / "c.toml")
    assert code == 2 and "singular" in err


def test_routing_import_keeps_urdf_path_and_priors(capsys, tmp_path):
    """tx40 (URDF kinematics, [[actuators]] priors) re-imported into another folder: loads, priors kept by row."""
    G = coupling(load_device(bundled("tx40"))).G
    (tmp_path / "g.txt").write_text("\n".join(" ".join(map(str, r)) for r in G))
    code, _, err = run_cli(capsys, "routing", "import", "tx40", tmp_path / "g.txt", "--out", tmp_path / "tx.toml")
    assert code == 0, err
    new, old = load_device(tmp_path / "tx.toml"), load_device(bundled("tx40"))
    np.testing.assert_array_equal(new.motor_joint_matrix(), G)
    assert [a.encoder_offset for a in new.actuators] == [a.encoder_offset for a in old.actuators]


# ---- ros2_control --------------------------------------------------------------------------------------------

def _ros2_actuator_positions(xml_text: str, q: dict) -> dict:
    """Actuator positions from joint positions with ros2_control's documented joint-to-actuator formulas."""
    root = ET.fromstring(xml_text)
    out = {}
    for t in root.iter("transmission"):
        kind = t.find("plugin").text.split("/")[-1]
        acts = [(a.get("name"), float(a.find("mechanical_reduction").text)) for a in t.findall("actuator")]
        jts = [(j.get("name"), float(j.find("mechanical_reduction").text), float(j.find("offset").text))
               for j in t.findall("joint")]
        if kind == "SimpleTransmission":
            (jn, n, off), = jts
            out[acts[0][0]] = n * (q[jn] - off)
        else:
            (a1, na1), (a2, na2) = acts
            (j1, nj1, o1), (j2, nj2, o2) = jts
            x1, x2 = q[j1] - o1, q[j2] - o2
            if kind == "DifferentialTransmission":
                out[a1], out[a2] = na1 * (nj1 * x1 + nj2 * x2), na2 * (nj1 * x1 - nj2 * x2)
            else:
                out[a1], out[a2] = nj1 * na1 * x1, na2 * (x1 + nj2 * x2)
    return out


def test_ros2_control_differential_and_simple(capsys, tmp_path):
    G = np.array([[50.0, 0, 0], [0, 30.0, 18.0], [0, -20.0, 12.0]])       # simple + a differential pair
    path = actuator_device(tmp_path, G, name="diffwrist")
    out = tmp_path / "diff.urdf"
    code, so, err = run_cli(capsys, "export", "ros2-control", path, "--out", out, "--json")
    assert code == 0, err
    kinds = [t["type"] for t in json.loads(so)["transmissions"]]
    assert kinds == ["SimpleTransmission", "DifferentialTransmission"]
    dev = load_device(path)
    q = np.array([0.3, -0.2, 0.45])
    qa = _ros2_actuator_positions(out.read_text(), dict(zip(coupling(dev).joints, q)))
    np.testing.assert_allclose([qa[m] for m in coupling(dev).motors], G @ q, rtol=1e-12)


def test_ros2_control_refuses_what_it_cannot_express(capsys, tmp_path):
    code, _, err = run_cli(capsys, "export", "ros2-control", "lexos", "--out", tmp_path / "l.urdf")
    assert code == 2 and "couples at most two joints" in err and "\n" not in err.strip()
    assert not (tmp_path / "l.urdf").exists()
    code, _, err = run_cli(capsys, "export", "ros2-control", "tx40", "--out", tmp_path / "t.urdf")
    assert code == 2 and "--four-bar" in err and "motor6" in err
    code, _, err = run_cli(capsys, "export", "ros2-control", "tx40", "--four-bar", "--out", tmp_path / "t.urdf")
    assert code == 0, err
    dev = load_device(bundled("tx40"))
    c = coupling(dev)
    q = np.linspace(-0.4, 0.5, 6)
    off = np.array([a.encoder_offset for a in dev.actuators])
    qa = _ros2_actuator_positions((tmp_path / "t.urdf").read_text(), dict(zip(c.joints, q)))
    np.testing.assert_allclose([qa[m] for m in c.motors], c.G @ (q - off), rtol=1e-12, atol=1e-12)


# ---- MuJoCo --------------------------------------------------------------------------------------------------

mujoco = pytest.importorskip("mujoco", reason="the mujoco package (the `test` extra) is not installed")


def _rk4_oracle(device, u_of_t, q0, dt: float, steps: int) -> np.ndarray:
    """Independent integration: Pinocchio's M(q) and h(q, q̇) plus the rotors Gᵀ J_r G, RK4 at dt, the motor torques
    u_of_t(k dt) held over step k."""
    import pinocchio as pin

    from tendyn.device.rigid_body import pinocchio_model

    model = pinocchio_model(device)
    data = model.createData()
    G = np.asarray(device.motor_joint_matrix(), float)
    if device.actuators:
        Jr = np.array([a.rotor_inertia for a in device.actuators])
    elif device.drives:
        Jr = np.array([d.motor.rotor_inertia for d in device.drives])
    else:
        Jr = np.array([t.motor.rotor_inertia for t in device.transmissions])
    rotor = G.T @ np.diag(Jr) @ G

    def f(u, x):
        q, v = x[:len(q0)], x[len(q0):]
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        h = pin.nonLinearEffects(model, data, q, v)
        return np.concatenate([v, np.linalg.solve(M + rotor, G.T @ u - h)])

    x = np.concatenate([q0, np.zeros_like(q0)])
    out = [x[:len(q0)].copy()]
    for k in range(steps):
        u = u_of_t(k * dt)                  # held over the step, as MuJoCo holds ctrl
        k1 = f(u, x)
        k2 = f(u, x + dt / 2 * k1)
        k3 = f(u, x + dt / 2 * k2)
        k4 = f(u, x + dt * k3)
        x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out.append(x[:len(q0)].copy())
    return np.array(out)


def _mujoco_run(xml: str, u_of_t, q0, dt: float, steps: int) -> np.ndarray:
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qpos[:] = q0
    out = [d.qpos.copy()]
    for k in range(steps):
        d.ctrl[:] = u_of_t(k * dt)   # RK4 holds the control over the step; the oracle samples it the same way
        mujoco.mj_step(m, d)
        out.append(d.qpos.copy())
    return np.array(out)


def _tx40_with_rotors(folder: Path) -> Path:
    """The TX40 file with rotor inertias (its priors are 0, and its last link has almost no inertia about its axis:
    M would be singular), the URDF path made absolute."""
    src = Path(bundled("tx40"))
    text = src.read_text().replace('urdf = "tx40.urdf"', f'urdf = "{src.parent / "tx40.urdf"}"')
    text = text.replace("[[actuators]]\n", "[[actuators]]\nrotor_inertia = 2e-5\n")
    path = folder / "tx40r.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("device", ["generated_spatial", "tx40", "zero_diagonal"])
def test_mjcf_round_trip_lossless_agrees_within_1e_6_rad(tmp_path, device):
    """The exported model, lossless, simulated by MuJoCo (RK4) and by an independent RK4 integration of the
    device's rigid body with the coupling: joint trajectories agree within 1e-6 rad over 0.3 s."""
    from tendyn.interop.mjcf import to_mjcf

    path = {"generated_spatial": lambda: write_cable_device(tmp_path, 3, planar=False, seed=4),
            "tx40": lambda: _tx40_with_rotors(tmp_path),
            "zero_diagonal": lambda: actuator_device(tmp_path, ZERO_DIAGONAL)}[device]()
    dev = load_device(path)
    n_m = coupling(dev).n_motors
    amp = 0.02 if device == "tx40" else 0.01
    u_of_t = lambda t: amp * np.sin(2 * np.pi * (1.0 + np.arange(n_m)) * t + np.arange(n_m))   # noqa: E731
    q0 = 0.1 * np.cos(np.arange(coupling(dev).n_joints))
    dt, steps = 1e-3, 300
    xml = to_mjcf(dev, timestep=dt, integrator="RK4", limits=False, losses=False)
    q_mj = _mujoco_run(xml, lambda t: u_of_t(t), q0, dt, steps)
    q_ref = _rk4_oracle(dev, u_of_t, q0, dt, steps)
    moved = np.abs(q_ref[-1] - q0).max()
    assert moved > 1e-3, "the test must move the joints"
    assert np.abs(q_mj - q_ref).max() < 1e-6


@pytest.mark.parametrize("differential", [False, True], ids=["serial", "differential"])
@pytest.mark.parametrize("coulomb", [False, True], ids=["viscous", "viscous_and_coulomb"])
def test_mjcf_round_trip_with_the_losses_mujoco_expresses_agrees_with_the_twin(tmp_path, differential, coulomb):
    """The exported losses simulated: a generated 3-joint spatial device whose losses are only what MuJoCo can
    carry (ν, and τ0 when ``coulomb``; no β, bearings or reducers), MuJoCo (implicitfast) against the twin
    (tendyn's simulator: losses from the statics' branch sites, another code path), same step, same held
    torques. Viscous only: both are the same implicit damping (measured 4e-14 rad); with τ0 the export makes
    MuJoCo's friction as stiff as it accepts (measured 1.3e-6 rad; MuJoCo's default soft friction: 8e-3 rad,
    which the 1e-5 band would catch) over about 1 rad of motion in 0.3 s."""
    import re

    from tendyn import _core
    from tendyn.interop.mjcf import to_mjcf
    from tendyn.sim.model import run_log, sim_model

    path = write_cable_device(tmp_path, 3, planar=False, seed=4, beta=False, reducers=False,
                              differential=differential)
    if not coulomb:
        path.write_text(re.sub(r"tau0 = [0-9.e-]+", "tau0 = 0.0", path.read_text()))
    dev = load_device(path)
    dt, steps, n = 1e-4, 3000, 3
    u = np.array([0.05 * np.sin(2 * np.pi * (1.0 + np.arange(n)) * k * dt + np.arange(n)) for k in range(steps)])
    m = mujoco.MjModel.from_xml_string(to_mjcf(dev, timestep=dt, limits=False, losses=True))
    d = mujoco.MjData(m)
    q_mj = []
    for k in range(steps):
        q_mj.append(d.qpos.copy())
        d.ctrl[:] = u[k]
        mujoco.mj_step(m, d)
    twin = sim_model(dev, rate_hz=1 / dt, control_hz=1 / dt, friction=True, sensors=False)
    z = np.zeros_like(u)
    q_twin = run_log(twin, _core.SimData(twin), z, z, u, z, 1)["q_joint"]    # row k: the state before step k
    lossless = mujoco.MjModel.from_xml_string(to_mjcf(dev, timestep=dt, limits=False, losses=False))
    assert np.abs(q_twin[-1]).max() > 0.5, "the test must move the joints"
    assert m.ntendon > lossless.ntendon, "the losses must be exported (else the agreement says nothing)"
    assert np.abs(np.array(q_mj) - q_twin).max() < (1e-5 if coulomb else 1e-9)


def test_mjcf_export_cli_losses_and_comment(capsys, tmp_path):
    """lexos: one tendon per motor (coefficients R_m⁻¹K row), one per lossy branch with Ṡ_ib = Σ_{j=b..i} K_ij q̇_j,
    frictionloss τ0 and damping ν (S0 eq. 12); β, reducers and pretension named in the comment; MuJoCo loads it."""
    out = tmp_path / "lexos.xml"
    code, so, err = run_cli(capsys, "export", "mjcf", "lexos", "--out", out, "--json")
    assert code == 0, err
    text = out.read_text()
    assert "friction.beta" in text and "reducer_efficiency" in text
    assert any("beta" in m for m in json.loads(so)["not_expressed"])
    dev = load_device(bundled("lexos"))
    arr = dev.routing_arrays()
    K, r_m = arr["K"], arr["motor_radius"]
    root = ET.fromstring(text)
    fixed = {f.get("name"): f for f in root.iter("fixed")}
    names = dev.joint_names
    for i, t in enumerate(dev.transmissions):
        coefs = {j.get("joint"): float(j.get("coef")) for j in fixed[t.name].iter("joint")}
        assert coefs == pytest.approx({names[j]: K[i, j] / r_m[i] for j in range(i + 1)})
        for b in range(i + 1):
            br = fixed[f"{t.name}_branch{b}"]
            assert float(br.get("frictionloss")) == arr["tau0"][i, b] and float(br.get("damping")) == arr["nu"][i, b]
            coefs = {j.get("joint"): float(j.get("coef")) for j in br.iter("joint")}
            assert coefs == pytest.approx({names[j]: K[i, j] for j in range(b, i + 1)})
    mujoco.MjModel.from_xml_path(str(out))


@pytest.mark.parametrize("device", ["tx40", "cea_branch"])
def test_mjcf_loads_for_geared_and_closed_loop_devices(capsys, tmp_path, device):
    out = tmp_path / f"{device}.xml"
    code, _, err = run_cli(capsys, "export", "mjcf", device, "--out", out)
    assert code == 0, err
    m = mujoco.MjModel.from_xml_path(str(out))
    assert m.nu == coupling(load_device(bundled(device))).n_motors
    if device == "cea_branch":
        assert m.neq > 0 and "stiffness_motor" in out.read_text()


def test_bad_inputs_are_one_line_and_exit_2(capsys, tmp_path):
    src = write_cable_device(tmp_path, 2, seed=2)
    (tmp_path / "g.json").write_text('{"coupling": {"JointToActuatorPosition": [[1, 0], [0, 2]]}}')
    cases = [
        (["routing", "import", src, tmp_path / "g.json", "--out", tmp_path / "x.txt"], ".toml"),
        (["routing", "import", src, tmp_path / "missing.json", "--out", tmp_path / "x.toml"], "not found"),
        (["routing", "import", src, tmp_path / "g.json", "--format", "icub", "--out", tmp_path / "x.toml"], "not XML"),
        (["routing", "import", src, tmp_path / "g.json", "--out", tmp_path / "nofolder" / "x.toml"], "does not exist"),
        (["routing", "import", "mcgill_bench", tmp_path / "g.json", "--out", tmp_path / "x.toml"], "tendon bench"),
        (["export", "mjcf", "mcgill_bench", "--out", tmp_path / "m.xml"], "tendon bench"),
        (["export", "mjcf", "lexos", "--out", tmp_path / "m.urdf"], ".xml"),
        (["export", "ros2-control", "lexos", "--out", tmp_path / "m.comp"], ".urdf"),
    ]
    for argv, words in cases:
        code, _, err = run_cli(capsys, *argv)
        assert code == 2, (argv, err)
        assert len(err.strip().splitlines()) == 1 and words in err, (argv, err)
    assert not list(tmp_path.glob("x.*")) and not list(tmp_path.glob("m.*"))
