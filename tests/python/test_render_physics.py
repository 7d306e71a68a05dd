"""The renderer's physics can fail (issue 22): each term of S0 eq. 23 (ERRATA) against an oracle that does not use
render.hpp — the wall's energy balance from the handle positions (damping dissipates), the friction force against
the sliding velocity from finite differences (the anchor trails the proxy), the texture's spatial period from the
zero crossings along the path. The handle moves on joint-space paths of L-EXOS, one cycle per control period."""

import numpy as np
import pytest

from tendyn import _core
from tendyn.control import Compensator, Renderer, chain_model
from tendyn.device import compile_device, load_device
from tendyn.devices import bundled

RATE_HZ = 1000.0
Q0 = np.array([0.3, 0.6, 0.0, 1.2])


@pytest.fixture(scope="module")
def lexos():
    return compile_device(load_device(bundled("lexos")))


def _handle(lexos, q):
    chain = chain_model(lexos)
    data = _core.ChainData(chain)
    _core.chain_forward_kinematics(chain, data, np.asarray(q, float))
    return np.array(data.ee_position)


def _render(lexos, path, plane_z, **kw):
    """Run the renderer along the joint path against the plane z >= plane_z; per cycle X̂, X_god, F_d, F_fr, F_T,
    the normal and the contact flag."""
    comp = Compensator.from_device(lexos, underestimation=0.0, rate_hz=RATE_HZ)
    texture = kw.pop("texture", None)
    r = Renderer(comp, **kw).add_plane([0.0, 0.0, 1.0], plane_z)
    if texture:
        r.set_texture(*texture)
    tr = lexos.transmission
    rec = {k: [] for k in ("x_hat", "x_god", "force", "force_friction", "force_texture", "normal", "contact")}
    for q in path:
        r.cycle(tr.motor_from_joint(q))
        for k in rec:
            rec[k].append(np.array(getattr(r.data, "in_contact" if k == "contact" else k), float))
    return {k: np.array(v) for k, v in rec.items()}


def _press_path(lexos, depth=0.005, period=2.0):
    """Into the plane z = top and out again along joint 2, depth(t) ∝ sin(π t / period): (path, top)."""
    dq = np.array([0.0, 1.0, 0.0, 0.0])
    step = 1e-3 if _handle(lexos, Q0 + 1e-3 * dq)[2] > _handle(lexos, Q0)[2] else -1e-3
    dz = (_handle(lexos, Q0 + step * dq)[2] - _handle(lexos, Q0 - step * dq)[2]) / (2 * abs(step))
    amplitude = (depth + 0.002) / abs(dz)          # joint-2 travel [rad] that reaches `depth` below the top
    t = np.arange(int(period * RATE_HZ) + 1) / RATE_HZ
    s = -np.sign(step) * amplitude * np.sin(np.pi * t / period)   # downward into the solid
    top = _handle(lexos, Q0)[2] - 0.002
    return [Q0 + si * dq for si in s], top


def _wall_energy(rec) -> float:
    """Work the rendered force does on the hand [J], trapezoid rule on the positions X̂ (exact for a spring)."""
    f, x = rec["force"], rec["x_hat"]
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(x, axis=0)))


def test_wall_damping_dissipates_the_energy_the_oracle_predicts(lexos):
    """In and out of a stiff wall: the spring alone gives the hand its energy back (E ≈ 0); damping K_d takes
    −K_d ∫ (n·Ẋ)² dt out of it, with n·Ẋ from finite differences of the handle positions. A flipped damping sign
    (the wall injects energy) fails."""
    path, top = _press_path(lexos)
    spring = _render(lexos, path, top, stiffness=2500.0, damping=0.0)
    kd = 20.0
    damped = _render(lexos, path, top, stiffness=2500.0, damping=kd)
    assert 0.3 * len(path) < damped["contact"].sum() < len(path)
    e_spring, e_damped = _wall_energy(spring), _wall_energy(damped)
    vn = np.gradient(damped["x_hat"][:, 2], 1.0 / RATE_HZ)          # n = +z
    inside = damped["contact"].astype(bool)
    oracle = -kd * float(np.sum(vn[inside] ** 2)) / RATE_HZ
    assert abs(e_spring) < 0.05 * abs(oracle)
    assert e_damped - e_spring < 0.0
    assert e_damped - e_spring == pytest.approx(oracle, rel=0.2)


APPROACH = 200


def _slide_path(lexos, n=1000, step=1.5e-3):
    """Down into the plane along joint 2 (APPROACH cycles, from free space: the proxy enters from outside), then
    along joint 1 (a horizontal-ish arc) from Q0; the plane sits 3 mm above the arc's highest point."""
    arc = [Q0 + np.array([step * k, 0.0, 0.0, 0.0]) for k in range(n)]
    top = max(_handle(lexos, q)[2] for q in arc) + 0.003
    dq = np.array([0.0, 1.0, 0.0, 0.0])
    dz = (_handle(lexos, Q0 + 1e-4 * dq)[2] - _handle(lexos, Q0 - 1e-4 * dq)[2]) / 2e-4
    lift = (top + 0.002 - _handle(lexos, Q0)[2]) / dz              # joint-2 offset putting the handle 2 mm above
    approach = [Q0 + lift * (1 - k / APPROACH) * dq for k in range(APPROACH)]
    return approach + arc, top


def test_surface_friction_opposes_the_sliding_velocity_and_saturates_at_mu_fn(lexos):
    """The stick anchor trails the proxy: in slip F_fr = −μ |F_n| v_t/|v_t|, with the tangential velocity v_t from
    finite differences of X_god. An anchor dragged on the wrong side pushes the hand along and fails."""
    mu, k = 0.4, 2000.0
    path, top = _slide_path(lexos)
    rec = {key: v[APPROACH:] for key, v in _render(lexos, path, top, stiffness=k, surface_friction=mu).items()}
    assert rec["contact"].all()
    v = np.gradient(rec["x_god"], 1.0 / RATE_HZ, axis=0)
    v[:, 2] = 0.0                                                   # tangential (n = +z)
    fn = k * (rec["x_god"][:, 2] - rec["x_hat"][:, 2])
    ff = rec["force_friction"]
    slipping = np.abs(np.linalg.norm(ff, axis=1) - mu * fn) < 1e-9 * (1 + mu * fn)
    assert slipping[50:].all()                                     # past the first millimetres it slides
    cos = np.sum(ff * v, axis=1) / (np.linalg.norm(ff, axis=1) * np.linalg.norm(v, axis=1))
    assert np.all(cos[10:] < 0.0)                                  # against the motion from the start
    assert np.all(cos[len(cos) // 2:] < -0.99)                     # and exactly so once the turn is past


def test_texture_period_is_the_spatial_period_lambda(lexos):
    """F_T = a_T |F_n| sin(2π X_god·e/λ) n: along the path the normal texture force changes sign every λ/2 of
    X_god·e (counted zero crossings, no formula of render.hpp); a phase off by 2π (period 2πλ) fails."""
    lam, a = 0.01, 0.2
    path, top = _slide_path(lexos)
    x = np.array([_handle(lexos, q) for q in path[APPROACH:]])
    e = x[-1] - x[0]
    e[2] = 0.0
    e /= np.linalg.norm(e)
    rec = {key: v[APPROACH:] for key, v in _render(lexos, path, top, stiffness=2000.0, texture=(a, lam, e)).items()}
    assert rec["contact"].all()
    s = rec["x_god"] @ e
    ft = np.sum(rec["force_texture"] * rec["normal"], axis=1)
    crossings = np.flatnonzero(np.sign(ft[1:]) != np.sign(ft[:-1]))
    span = abs(s[crossings[-1]] - s[crossings[0]])
    assert len(crossings) > 8
    assert 2 * span / (len(crossings) - 1) == pytest.approx(lam, rel=0.05)
    fn = 2000.0 * (rec["x_god"][:, 2] - rec["x_hat"][:, 2])
    assert np.max(np.abs(ft)) == pytest.approx(a * np.max(fn), rel=0.05)
