"""The real-time compensator and renderer (include/tendyn/compensator.hpp, chain.hpp, render.hpp): C10, C46."""

import math

import numpy as np
import pytest

from tendyn import _core
from tendyn.claims import assert_claim
from tendyn.control import Compensator, Renderer, chain_model
from tendyn.device import compile_device, load_device
from tendyn.device.rigid_body import dh_forward_kinematics
from tendyn.devices import bundled


@pytest.fixture(scope="module")
def lexos():
    return compile_device(load_device(bundled("lexos")))


def _random_q(rng, n=4):
    return rng.uniform(-1.5, 1.5, size=n)


def test_chain_gravity_equals_pinocchio_generalized_gravity(lexos):
    """The core's allocation-free gravity (chain.hpp, no Pinocchio) = pinocchio.computeGeneralizedGravity on
    L-EXOS at random configurations, to 1e-12 (independent routes)."""
    import pinocchio as pin

    chain = chain_model(lexos)
    data = _core.ChainData(chain)
    pm = lexos.pinocchio_model
    pd = pm.createData()
    rng = np.random.default_rng(11)
    for _ in range(200):
        q = _random_q(rng)
        _core.chain_gravity_torque(chain, data, q)
        ref = pin.computeGeneralizedGravity(pm, pd, q)
        np.testing.assert_allclose(np.array(data.gravity_torque), ref, rtol=0, atol=1e-12)


def test_chain_end_effector_matches_dh_kinematics_and_finite_differences(lexos):
    """X̂ of the chain = the DH table's own forward kinematics (oracle); its Jacobian = finite differences."""
    chain = chain_model(lexos)
    data = _core.ChainData(chain)
    rng = np.random.default_rng(12)
    for _ in range(20):
        q = _random_q(rng)
        _core.chain_forward_kinematics(chain, data, q)
        x = np.array(data.ee_position)
        np.testing.assert_allclose(x, dh_forward_kinematics(lexos.device, q)[-1][:3, 3], atol=1e-13)
        J = np.array(data.ee_jacobian)
        h = 1e-6
        for j in range(4):
            dq = np.zeros(4)
            dq[j] = h
            _core.chain_forward_kinematics(chain, data, q + dq)
            xp = np.array(data.ee_position)
            _core.chain_forward_kinematics(chain, data, q - dq)
            xm = np.array(data.ee_position)
            np.testing.assert_allclose((xp - xm) / (2 * h), J[:, j], atol=1e-8)


def test_C10_compensator_equals_python_statics_with_losses_on_random_inputs(claims_ctx):
    """C10/C46: a compensator cycle = gravity (Pinocchio) + the statics with losses of the Python face (S0 eqs.
    4, 6, 9–12, corrected: ERRATA), friction part scaled by k and faded in the velocity band; random inputs."""
    assert_claim("C10", claims_ctx)


def test_C46_friction_part_scales_with_the_underestimation_factor(lexos):
    """C46: friction compensated with under-estimated coefficients: the friction part is exactly k times the
    model's, the gravity part unchanged."""
    rng = np.random.default_rng(14)
    qm0, qd = rng.uniform(-5, 5, 4), np.array([10.0, -7.0, 4.0, 12.0])
    full = Compensator.from_device(lexos, underestimation=1.0, velocity_band=0.0, velocity_cutoff_hz=0.0)
    part = full.with_settings(underestimation=0.6)
    for c in (full, part):
        c.cycle(qm0)
        c.cycle(qm0 + qd / 1000.0)
    np.testing.assert_allclose(np.array(part.data.torque_motor_friction),
                               0.6 * np.array(full.data.torque_motor_friction), rtol=1e-14)
    np.testing.assert_allclose(np.array(part.data.torque_motor_lossless), np.array(full.data.torque_motor_lossless))
    assert np.all(np.abs(np.array(full.data.torque_motor_friction)) > 1e-3)


def test_velocity_band_fades_friction_to_zero_at_rest(lexos):
    comp = Compensator.from_device(lexos, underestimation=1.0, velocity_band=1.0, velocity_cutoff_hz=0.0)
    qm = np.array([1.0, 2.0, 3.0, 4.0])
    for v, w in ((0.0, 0.0), (0.25, 0.25), (0.5, 0.5), (2.0, 1.0)):
        comp.reset()
        comp.cycle(qm)
        comp.cycle(qm + v / 1000.0)
        np.testing.assert_allclose(np.array(comp.data.friction_weight), w, atol=1e-9)
    comp.reset()
    comp.cycle(qm)
    comp.cycle(qm)
    np.testing.assert_allclose(np.array(comp.data.torque_motor_friction), 0.0, atol=0)


@pytest.mark.parametrize("cutoff_hz", [5.0, 20.0, 50.0])
def test_velocity_filter_is_minus_3db_at_its_cutoff_in_hz(lexos, cutoff_hz):
    """The velocity estimate's gain at the cut-off frequency [Hz] is 1/√2 (−3 dB): a cut-off in Hz used as
    rad/s would put the −3 dB point 2π lower and fail here."""
    comp = Compensator.from_device(lexos, velocity_cutoff_hz=cutoff_hz)
    rate = comp.model.rate_hz
    w = 2 * np.pi * cutoff_hz
    amp = 0.5
    steps = int(rate * (20 / cutoff_hz + 1.0))
    est = np.empty(steps)
    for k in range(steps):
        qm = np.full(4, amp * math.sin(w * k / rate))
        comp.cycle(qm)
        est[k] = comp.data.qd_motor[0]
    tail = est[steps // 2:]
    gain = 0.5 * (tail.max() - tail.min()) / (amp * w)
    assert gain == pytest.approx(1 / math.sqrt(2), rel=0.02), gain


def test_compensator_file_round_trip(lexos, tmp_path):
    comp = Compensator.from_device(lexos, underestimation=0.8, velocity_band=0.3, velocity_cutoff_hz=25.0)
    path = tmp_path / "lexos.comp"
    comp.export(path)
    back = Compensator.load(path, expected_device="L-EXOS")
    assert back.text() == comp.text()
    rng = np.random.default_rng(15)
    for _ in range(20):
        qm, tj = rng.normal(size=4), rng.normal(size=4)
        np.testing.assert_array_equal(back.cycle(qm, tj), comp.cycle(qm, tj))
    # the transmission reader takes the same file (it stops at the sections)
    from tendyn.transmission import Transmission

    assert Transmission.load(path).to_dict()["K"].tolist() == lexos.transmission.K.tolist()


def _edit(text, key, new):
    lines = []
    for line in text.splitlines():
        if line.split(" ")[0] == key:
            if new is not None:
                lines.append(new)
        else:
            lines.append(line)
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("what,edit,needle", [
    ("missing transmission", lambda t: "\n".join(ln for ln in t.splitlines()
                                                 if ln.split(" ")[0] not in ("motor_radius", "K", "driven_radius",
                                                                             "reducer_ratio")) + "\n", "motor_radius"),
    ("NaN mass", lambda t: _edit(t, "mass", "mass 2 nan 1.2 0.8"), "mass"),
    ("NaN setting", lambda t: _edit(t, "velocity_band", "velocity_band nan"), "velocity_band"),
    ("NaN loss", lambda t: _edit(t, "nu", "nu " + " ".join(["nan"] + ["1"] * 15)), "nu"),
    ("no chain", lambda t: t[:t.index("section chain")], "section chain"),
    ("missing setting", lambda t: _edit(t, "rate_hz", None), "rate_hz"),
    ("unknown field", lambda t: t + "stiffness 3\n", "stiffness"),
])
def test_bad_compensator_file_is_refused_naming_the_field(lexos, tmp_path, what, edit, needle):
    text = Compensator.from_device(lexos).text()
    path = tmp_path / "bad.comp"
    path.write_text(edit(text))
    with pytest.raises(ValueError, match=needle) as info:
        Compensator.load(path)
    assert "bad.comp" in str(info.value), what


def test_compensator_file_of_another_device_is_refused(lexos, tmp_path):
    path = tmp_path / "lexos.comp"
    Compensator.from_device(lexos).export(path)
    with pytest.raises(ValueError, match="device: the file is for 'L-EXOS', expected 'CEA branch'"):
        Compensator.load(path, expected_device="CEA branch")
    # a chain of another device (3 joints) behind L-EXOS's 4 transmissions
    text = Compensator.from_device(lexos).text()
    head, chain = text.split("section chain 1\n")
    chain_lines = chain.splitlines()
    keep = {"n": "n 3", "parent": "parent -1 0 1", "prismatic": "prismatic 0 0 0", "mass": "mass 1 1 1"}
    out = []
    for ln in chain_lines:
        key = ln.split(" ")[0]
        if key in keep:
            out.append(keep[key])
        elif key in ("placement", "axis", "com"):
            vals = ln.split(" ")[1:]
            per = 12 if key == "placement" else 3
            out.append(" ".join([key] + vals[: 3 * per]))
        elif key == "ee_joint":
            out.append("ee_joint 2")
        else:
            out.append(ln)
    path.write_text(head + "section chain 1\n" + "\n".join(out) + "\n")
    with pytest.raises(ValueError, match="chain.n = 3: must equal the number of transmissions"):
        Compensator.load(path)


# ---- renderer (S0 eq. 23, C10) -------------------------------------------------------------------------

def _renderer_at(lexos, **kw):
    comp = Compensator.from_device(lexos, underestimation=0.0)
    return Renderer(comp, **kw)


def _handle(lexos, q):
    chain = chain_model(lexos)
    data = _core.ChainData(chain)
    _core.chain_forward_kinematics(chain, data, np.asarray(q, float))
    return np.array(data.ee_position)


Q0 = np.array([0.3, 0.6, 0.0, 1.2])


def test_C10_render_plane_force_is_stiffness_times_penetration_along_the_normal(lexos):
    """C10, S0 eq. 23: against a plane the proxy stays on the surface and F_d = K_st (X_god − X̂) along the normal;
    the motor torques are the compensator's for Jᵀ F_d."""
    tr = lexos.transmission
    x0 = _handle(lexos, Q0)
    above = next(Q0 + np.array([0.0, dq, 0.0, 0.0]) for dq in np.linspace(-0.4, 0.4, 81)
                 if _handle(lexos, Q0 + np.array([0.0, dq, 0.0, 0.0]))[2] > x0[2] + 0.01)
    r = _renderer_at(lexos, stiffness=2500.0).add_plane([0, 0, 1], x0[2] + 0.004)
    r.cycle(tr.motor_from_joint(above))                      # free space above the plane
    assert not r.data.in_contact
    np.testing.assert_allclose(np.array(r.data.force), 0.0)
    torque = r.cycle(tr.motor_from_joint(Q0))                 # 4 mm into it
    assert r.data.in_contact
    np.testing.assert_allclose(np.array(r.data.x_god)[2], x0[2] + 0.004, atol=1e-12)
    np.testing.assert_allclose(np.array(r.data.force), [0, 0, 2500.0 * 0.004], atol=1e-9)
    comp = r.compensator
    J = np.array(comp.data.ee_jacobian)
    np.testing.assert_allclose(np.array(comp.data.torque_joint_wanted), J.T @ np.array(r.data.force), atol=1e-12)
    assert np.all(np.isfinite(torque)) and r.data.compute_time > 0


def test_render_sphere_keeps_the_proxy_on_the_surface_and_friction_saturates(lexos):
    """The god object slides on the sphere (|X_god − c| = r in contact); the Coulomb surface friction on the
    proxy never exceeds μ |F_n|; the texture term is along the normal."""
    tr = lexos.transmission
    path = [Q0 + np.array([0.004 * k, 0.0, 0.0, 0.0]) for k in range(300)]   # a horizontal arc (joint 1)
    pts = np.array([_handle(lexos, q) for q in path])
    direction = pts[-1] - pts[0]
    center = pts[150] - np.array([0.0, 0.0, 0.03])        # the arc passes 5 mm deep through the top
    assert np.linalg.norm(pts[0] - center) > 0.04
    r = _renderer_at(lexos, stiffness=2000.0, surface_friction=0.5).set_sphere(center, 0.035)
    r.set_texture(0.2, 0.01, direction)
    contacts = 0
    for q in path:
        r.cycle(tr.motor_from_joint(q))
        if r.data.in_contact:
            contacts += 1
            xg = np.array(r.data.x_god)
            assert abs(np.linalg.norm(xg - center) - 0.035) < 1e-9
            n = np.array(r.data.normal)
            fn = 2000.0 * np.linalg.norm(xg - np.array(r.data.x_hat))
            assert np.linalg.norm(np.array(r.data.force_friction)) <= 0.5 * fn + 1e-9
            assert abs(np.dot(np.array(r.data.force_friction), n)) < 1e-9
            np.testing.assert_allclose(np.cross(np.array(r.data.force_texture), n), 0.0, atol=1e-12)
    assert 20 < contacts < 290
