"""URDF descriptions: the same chain written as a URDF gives the same Pinocchio model, gravity and
simulator step as its DH description (L-EXOS exported to URDF here)."""

import numpy as np
import pinocchio as pin
import pytest

from tendyn import _core
from tendyn.device import DeviceError, load_device
from tendyn.device.rigid_body import joint_frames, rigid_body_model
from tendyn.devices import bundled
from tendyn.sim.model import run_log, sim_model


def urdf_of(device) -> str:
    """Write a device's DH chain as URDF: each link frame = the Pinocchio joint frame."""
    frames = joint_frames(device)
    parts = ['<robot name="exported">', '<link name="base"/>']
    parent = "base"
    for f in frames:
        xyz = " ".join(f"{v:.17g}" for v in f.placement[:3, 3])
        rpy = " ".join(f"{v:.17g}" for v in pin.rpy.matrixToRpy(f.placement[:3, :3]))
        I = f.inertia
        parts += [
            f'<link name="{f.name}_link"><inertial><origin xyz="{" ".join(f"{v:.17g}" for v in f.com)}" rpy="0 0 0"/>'
            f'<mass value="{f.mass:.17g}"/><inertia ixx="{I[0, 0]:.17g}" ixy="{I[0, 1]:.17g}" ixz="{I[0, 2]:.17g}" '
            f'iyy="{I[1, 1]:.17g}" iyz="{I[1, 2]:.17g}" izz="{I[2, 2]:.17g}"/></inertial></link>',
            f'<joint name="{f.name}" type="revolute"><parent link="{parent}"/><child link="{f.name}_link"/>'
            f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="0 0 1"/>'
            f'<limit lower="-3" upper="3" effort="100" velocity="10"/></joint>',
        ]
        parent = f"{f.name}_link"
    parts.append("</robot>")
    return "\n".join(parts)


def urdf_device(tmp_path, lexos):
    (tmp_path / "lexos.urdf").write_text(urdf_of(lexos))
    text = bundled("lexos").read_text()
    head, tail = text.split("[kinematics]", 1)
    tail = tail[tail.index("[[transmissions]]"):]
    (tmp_path / "lexos_urdf.toml").write_text(
        head + '[kinematics]\nconvention = "urdf"\nurdf = "lexos.urdf"\ngravity = [0.0, 0.0, -9.81]\n\n' + tail)
    return load_device(tmp_path / "lexos_urdf.toml")


def test_urdf_chain_equals_dh_chain(tmp_path, rng):
    lexos = load_device(bundled("lexos"))
    dev = urdf_device(tmp_path, lexos)
    assert dev.kinematics.convention == "urdf" and dev.n_joints == 4
    a, b = rigid_body_model(lexos), rigid_body_model(dev)
    da, db = _core.RigidBodyData(a), _core.RigidBodyData(b)
    for _ in range(20):
        q = rng.uniform(-1.5, 1.5, 4)
        _core.gravity_torque(a, da, q)
        _core.gravity_torque(b, db, q)
        np.testing.assert_allclose(db.gravity_torque, da.gravity_torque, rtol=1e-10, atol=1e-12)
    # and the simulator steps the same
    ma, mb = sim_model(lexos, sensors=False), sim_model(dev, sensors=False)
    sa, sb = _core.SimData(ma), _core.SimData(mb)
    q0 = np.array([0.1, 0.4, -0.2, 0.9])
    sa.reset(q0, 0)
    sb.reset(q0, 0)
    z = np.zeros((2000, 4))
    ff = np.tile([0.1, -0.05, 0.02, 0.03], (2000, 1))
    la = run_log(ma, sa, z, z, ff, z, 10)
    lb = run_log(mb, sb, z, z, ff, z, 10)
    np.testing.assert_allclose(lb["q_joint"], la["q_joint"], atol=1e-9)


def test_urdf_with_continuous_joint_is_refused(tmp_path):
    lexos = load_device(bundled("lexos"))
    dev = urdf_device(tmp_path, lexos)
    text = (tmp_path / "lexos.urdf").read_text().replace('type="revolute"', 'type="continuous"', 1)
    (tmp_path / "lexos.urdf").write_text(text)
    with pytest.raises(DeviceError, match="one-DOF"):
        joint_frames(load_device(tmp_path / "lexos_urdf.toml"))
    assert dev is not None


@pytest.mark.parametrize("old, new, words", [
    ('<mass value="', '<mass value="nan" old="', "<mass>: must be a finite number >= 0"),
    ('<mass value="', '<mass value="-1" old="', "<mass>: must be a finite number >= 0"),
    ('ixx="', 'ixx="inf" old="', "<inertia>: ixx … iyz must be finite"),
    ('ixx="', 'ixx="-5" old="', "not a physical inertia"),
    ('<origin xyz="', '<origin xyz="nan 0 0" old="', "<inertial><origin>: xyz and rpy must be finite"),
])
def test_urdf_with_an_impossible_inertial_is_refused_at_load(tmp_path, old, new, words):
    """A URDF `<mass value="nan">` loaded (Pinocchio keeps it): refused naming the file, the link and the field."""
    urdf_device(tmp_path, load_device(bundled("lexos")))
    text = (tmp_path / "lexos.urdf").read_text().replace(old, new, 1)
    (tmp_path / "lexos.urdf").write_text(text)
    with pytest.raises(DeviceError, match="lexos.urdf: link 'shoulder_abduction_link'") as info:
        load_device(tmp_path / "lexos_urdf.toml")
    assert words in str(info.value)
