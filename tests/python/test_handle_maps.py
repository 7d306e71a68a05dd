"""Maps at the handle of cable devices (issue 17 item 6): apparent mass, viscous and dry friction, on L-EXOS and on
generated cable devices (1, 2, 3 transmissions; planar and spatial), each against a route that shares no code
with :mod:`tendyn.analysis.handle_maps`:

* apparent mass — the C++ simulator (its own rigid body, cable constraints and rotors): a force on the handle at
  rest for one step, the handle's acceleration Ẍ = Λ⁻¹ F;
* viscous friction — power balance: F·Ẋ = Σ ν_i q̇_m,i² with the motor speeds from the core's kinematics
  (``Transmission.motor_from_joint``) and the least dissipating joint motion found by brute force;
* dry friction — virtual work, the same brute force over the joint motions that move the handle along u
  (F·u = Σ C_m0,i |q̇_m,i|), and its largest/smallest value over many directions;
* the equivalent friction of a device file — the Python branch law of the S0 pipeline (eqs. 18–19).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from tendyn.devices.generate import write_cable_device
from tendyn import _core
from tendyn.analysis.handle_maps import HandleModel, equivalent_motor_friction, handle_maps
from tendyn.device import compile_device, load_device
from tendyn.device.closed_loop import active_mass_matrix
from tendyn.devices import bundled

CASES = [(1, True), (2, True), (3, True), (2, False), (3, False)]


def _device(tmp_path, n, planar, seed=0):
    return load_device(write_cable_device(tmp_path, n, planar=planar, seed=1000 * n + 10 * planar + seed,
                                          rotor_inertia=1e-4))


def _devices(tmp_path):
    yield load_device(bundled("lexos"))
    for n, planar in CASES:
        yield _device(tmp_path, n, planar)


def _poses(model, rng, k=3):
    """k random poses inside the limits, away from singularities (cond(J_r) < 30)."""
    lo, hi = model.handle.active_limits()
    out = []
    while len(out) < k:
        q = rng.uniform(lo + 0.05 * (hi - lo), hi - 0.05 * (hi - lo))
        if model.handle.within_limits(q) and model.task(q)[3] < 30:
            out.append(q)
    return out


def _fd_jacobian(model, q, h=1e-6):
    """∂X/∂q [m/rad] by central differences of the handle position."""
    cols = []
    for i in range(len(q)):
        e = np.zeros(len(q))
        e[i] = h
        cols.append((model.handle.position(q + e) - model.handle.position(q - e)) / (2 * h))
    return np.column_stack(cols)


def _motor_speeds(device, qd):
    """q̇_m [rad/s] through the core's kinematics (linear: the motor angles of the joint angles q̇)."""
    return compile_device(device).transmission.motor_from_joint(qd)


def _handle_motions(model, q, u, z):
    """Joint velocities moving the handle at u (operator frame): a particular one plus z (s,) along the
    null space of the finite-difference Jacobian, shape (s, n)."""
    Jf = _fd_jacobian(model, q)
    q0 = np.linalg.lstsq(Jf, u, rcond=None)[0]
    _, s, Vt = np.linalg.svd(Jf)
    r = int(np.sum(s > 1e-6 * s[0]))
    N = Vt[r:].T
    if N.shape[1] == 0:
        return q0[None, :]
    assert N.shape[1] == 1, "brute force written for one redundant joint at most"
    return q0[None, :] + z[:, None] * N[:, 0][None, :]


def _brute_min(device, model, q, u, cost):
    """min over the joint motions that move the handle at u of cost(q̇_m) (dense grid, then a finer one)."""
    z = np.linspace(-50.0, 50.0, 4001)
    for _ in range(4):
        Qd = _handle_motions(model, q, u, z)
        vals = np.array([cost(_motor_speeds(device, qd)) for qd in Qd])
        k = int(np.argmin(vals))
        if len(z) == 1 or Qd.shape[0] == 1:
            return vals[k]
        step = z[1] - z[0]
        z = np.linspace(z[k] - 2 * step, z[k] + 2 * step, 401)
    return vals[k]


# --------------------------------------------------------------------------------------------------------
# apparent mass: the C++ simulator as the oracle
# --------------------------------------------------------------------------------------------------------

def _simulated_inverse_mass(device, q, basis, force=1.0):
    """(Ẍ per newton) in the basis: one simulator step from rest at q with the handle force F = force·U_r e_k as
    joint torques Jᵀ F, minus the same step without it (gravity cancels) — no friction, motors unpowered."""
    from tendyn.sim.model import sim_model

    m = sim_model(device, rate_hz=10_000.0, control_hz=10_000.0, friction=False, sensors=False)
    model = HandleModel(device)
    J = _fd_jacobian(model, q)
    na = len(q)
    z = np.zeros(na)

    def qdd(tau):
        d = _core.SimData(m)
        d.reset(np.asarray(q, float), 0)
        _core.step(m, d, z, z, z, np.asarray(tau, float))
        return np.array(d.qd) / m.dt

    base = qdd(z)
    cols = [basis.T @ J @ (qdd(J.T @ (force * basis[:, k])) - base) / force for k in range(basis.shape[1])]
    return np.column_stack(cols)


def test_apparent_mass_equals_the_simulated_response_to_a_handle_force(tmp_path, rng):
    for dev in _devices(tmp_path):
        model = HandleModel(dev)
        for q in _poses(model, rng, 2):
            p = model.at(q)
            measured = _simulated_inverse_mass(dev, q, p.basis)
            expected = np.linalg.inv(p.mass)
            assert np.allclose(measured, expected, rtol=1e-6, atol=1e-6 * np.abs(expected).max()), \
                (dev.name, q, measured, expected)


def test_rotor_inertia_is_reflected_through_the_transmission(tmp_path):
    """Λ with the rotors minus Λ without them is the rotors' share (G = R_m⁻¹K: a heavier handle)."""
    dev = load_device(bundled("lexos"))
    model = HandleModel(dev)
    q = np.array([0.2, 0.5, 0.1, 1.0])
    A = model.joint_mass_matrix(q)
    c = compile_device(dev)
    links = active_mass_matrix(c.pinocchio_model, *c.active_map, q)
    tr = c.transmission.matrices()
    G = np.linalg.solve(tr["R_m"], tr["K"])
    assert np.allclose(A - links, G.T @ np.diag(model.rotor_inertia) @ G, rtol=1e-12, atol=1e-15)
    assert np.all(model.rotor_inertia > 0)


# --------------------------------------------------------------------------------------------------------
# viscous friction: power balance
# --------------------------------------------------------------------------------------------------------

def _directions(tmp_path, rng, poses=2, directions=2):
    """(device, model, q, pose, w): random poses of every test device and random unit handle directions w in
    each pose's basis."""
    for dev in _devices(tmp_path):
        model = HandleModel(dev)
        for q in _poses(model, rng, poses):
            p = model.at(q)
            for _ in range(directions):
                w = rng.normal(size=p.task_dimension)
                yield dev, model, q, p, w / np.linalg.norm(w)


def test_viscous_map_is_the_least_dissipated_power(tmp_path, rng):
    """uᵀ B u = min over the joint motions moving the handle at u of Σ ν_i q̇_m,i² (brute force, core
    kinematics), and the map's own motion dissipates exactly F·Ẋ."""
    for dev, model, q, p, w in _directions(tmp_path, rng):
        nu = model.viscous_motor
        force = p.viscous @ w
        qd = model.joint_velocity(q, w, "viscous")
        power = float(np.sum(nu * _motor_speeds(dev, qd) ** 2))
        assert force @ w == pytest.approx(power, rel=1e-9)
        best = _brute_min(dev, model, q, p.basis @ w, lambda qm: float(np.sum(nu * qm ** 2)))
        assert force @ w == pytest.approx(best, rel=1e-5), (dev.name, q)


# --------------------------------------------------------------------------------------------------------
# dry friction: virtual work, brute force
# --------------------------------------------------------------------------------------------------------

def test_dry_friction_along_a_direction_is_the_least_coulomb_power(tmp_path, rng):
    """h(u) = min over the joint motions moving the handle along u of Σ C_m0,i |q̇_m,i| (virtual work)."""
    for dev, model, q, p, w in _directions(tmp_path, rng, directions=3):
        C = model.coulomb_motor
        u = p.basis @ w
        best = _brute_min(dev, model, q, u, lambda qm: float(np.sum(C * np.abs(qm))))
        assert p.dry_friction(u) == pytest.approx(best, rel=1e-5), (dev.name, q, u)


def test_dry_friction_extremes_over_directions(tmp_path, rng):
    """The largest and smallest dry friction (P's farthest vertex, P's nearest face) are reached in the directions
    the map names (brute force there) and bound the brute-force values in random directions."""
    for dev in _devices(tmp_path):
        model = HandleModel(dev)
        C = model.coulomb_motor
        coulomb = lambda qm: float(np.sum(C * np.abs(qm)))     # noqa: E731
        q = _poses(model, rng, 1)[0]
        p = model.at(q)
        (fmax, umax), (fmin, umin) = p.dry_friction_max(), p.dry_friction_min()
        assert _brute_min(dev, model, q, umax, coulomb) == pytest.approx(fmax, rel=1e-5), dev.name
        assert _brute_min(dev, model, q, umin, coulomb) == pytest.approx(fmin, rel=1e-5), dev.name
        W = rng.normal(size=(40, p.task_dimension))
        for w in W / np.linalg.norm(W, axis=1, keepdims=True):
            h = _brute_min(dev, model, q, p.basis @ w, coulomb)
            assert fmin * (1 - 1e-6) <= h <= fmax * (1 + 1e-6), dev.name


# --------------------------------------------------------------------------------------------------------
# the device file's friction, per transmission
# --------------------------------------------------------------------------------------------------------

def test_equivalent_friction_equals_the_branch_law_of_eqs_18_19(tmp_path):
    from tendyn.pipelines.s0_friction import true_global_friction

    for dev in _devices(tmp_path):
        arr = dev.routing_arrays()
        c, nu = equivalent_motor_friction(compile_device(dev).transmission)
        for i in range(dev.n_transmissions):
            c_ref, nu_ref = true_global_friction(arr, i, (2.0, 4.0, 6.0, 8.0, 10.0))
            assert c[i] == pytest.approx(c_ref, rel=1e-6) and nu[i] == pytest.approx(nu_ref, rel=1e-6), dev.name


def test_equivalent_friction_without_beta_and_reducers_is_the_sum_over_branches(tmp_path):
    """β = 0, η = 1, no bearings: C_m0 = r_m Σ_b τ0_b, ν = r_m² Σ_b ν_b (S0 eqs. 18–19, k' = r_m)."""
    dev = load_device(write_cable_device(tmp_path, 3, planar=False, reducers=False, beta=False, seed=7))
    arr = dev.routing_arrays()
    c, nu = equivalent_motor_friction(compile_device(dev).transmission)
    r_m = arr["motor_radius"]
    assert np.allclose(c, r_m * arr["tau0"].sum(1), rtol=1e-9)
    assert np.allclose(nu, r_m ** 2 * arr["nu"].sum(1), rtol=1e-9)


# --------------------------------------------------------------------------------------------------------
# identified values: FRICTION.json and PARAMS.json
# --------------------------------------------------------------------------------------------------------

def _friction_doc(dev, coulomb, viscous):
    """A FRICTION.json document (tendyn.friction/1, docs/friction-file.md) with the given values."""
    fits = [{"transmission": i + 1, "coulomb_motor": float(c), "viscous_motor": float(v), "coulomb_motor_std": 0.0,
             "viscous_motor_std": 0.0, "strategy": "S2", "residual_bound": None}
            for i, (c, v) in enumerate(zip(coulomb, viscous))]
    return {"format": "tendyn.friction/1", "device": dev.name, "n_transmissions": len(fits),
            "coulomb_motor": [f["coulomb_motor"] for f in fits], "viscous_motor": [f["viscous_motor"] for f in fits],
            "fits": fits}


def test_identified_mass_matrix_from_base_parameters_equals_the_device_file(tmp_path, rng):
    """The identification model's regressor (C++) with the twin's own base parameters gives the A(q) of the
    device file's route (Pinocchio crba + Gᵀ diag(I_r) G)."""
    from tendyn.ident import IdentModel

    for dev in _devices(tmp_path):
        im = IdentModel(dev)
        base = im.base
        xb = base.combination @ im.prior()
        params = [{"name": nm, "value": float(v), "expression": base.expression(i, im.standard_names)}
                  for i, (nm, v) in enumerate(zip(base.names, xb))]
        x = im.parameter_vector(params)
        model = HandleModel(dev)
        for q in _poses(model, rng, 2):
            assert np.allclose(im.mass_matrix(q, x), model.joint_mass_matrix(q), rtol=1e-8, atol=1e-12), dev.name


def test_cli_maps_on_a_cable_device(tmp_path, capsys):
    from tendyn.cli import main

    dev = _device(tmp_path, 2, True)
    code = main(["maps", str(dev.path), "--json", "--report", str(tmp_path / "rep")])
    out = capsys.readouterr()
    assert code == 0, out.err
    doc = json.loads(out.out)
    assert {f.name for f in (tmp_path / "rep").iterdir()} == {"handle_maps.png", "maps.json", "maps.txt",
                                                              "report.html"}
    assert doc["task_dimension"] == 2 and doc["stiffness"] is None
    assert 0 < doc["min_apparent_mass_kg"] <= doc["max_apparent_mass_kg"]
    assert 0 < doc["min_dry_friction_N"] <= doc["max_dry_friction_N"]
    assert doc["reference_pose"]["dry_friction_along_axes_N"].count(None) == 1      # the plane's normal
    # FRICTION.json: its values are used, and the dry friction scales with them
    fr = tmp_path / "friction.json"
    c = np.array(doc["coulomb_motor_N_m"])
    fr.write_text(json.dumps(_friction_doc(dev, 2 * c, np.array(doc["viscous_motor_N_m_s_per_rad"]))))
    assert main(["maps", str(dev.path), "--friction", str(fr), "--json"]) == 0
    doc2 = json.loads(capsys.readouterr().out)
    assert doc2["coulomb_motor_N_m"] == pytest.approx(list(2 * c))
    assert doc2["max_dry_friction_N"] == pytest.approx(2 * doc["max_dry_friction_N"], rel=1e-9)
    assert doc2["max_apparent_mass_kg"] == pytest.approx(doc["max_apparent_mass_kg"], rel=1e-12)
    assert "identified" in doc2["sources"]["friction"]


def test_cli_maps_lexos_with_identified_parameters(tmp_path, capsys):
    from tendyn.cli import main
    from tendyn.ident import IdentModel

    dev = load_device(bundled("lexos"))
    im = IdentModel(dev)
    xb = im.base.combination @ im.prior()
    p = tmp_path / "params.json"
    p.write_text(json.dumps({"params": [{"name": nm, "value": float(v),
                                         "expression": im.base.expression(i, im.standard_names)}
                                        for i, (nm, v) in enumerate(zip(im.base.names, xb))]}))
    assert main(["maps", "lexos", "--points", "3", "--json"]) == 0
    ref = json.loads(capsys.readouterr().out)
    assert main(["maps", "lexos", str(p), "--points", "3", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["max_apparent_mass_kg"] == pytest.approx(ref["max_apparent_mass_kg"], rel=1e-8)
    assert "identified" in doc["sources"]["inertia"] and doc["task_dimension"] == 3


def test_cli_maps_bad_inputs_are_one_line(tmp_path, capsys):
    from tendyn.cli import main

    dev = load_device(bundled("lexos"))
    other = _device(tmp_path, 2, True)
    good = _friction_doc(dev, [0.01] * 4, [0.001] * 4)
    files = {}
    for name, doc in (("other", _friction_doc(other, [0.01] * 2, [0.001] * 2)),
                      ("negative", {**good, "coulomb_motor": [0.01, -0.01, 0.01, 0.01],
                                    "fits": [dict(f, coulomb_motor=-0.01) if f["transmission"] == 2 else f
                                             for f in good["fits"]]})):
        files[name] = tmp_path / f"{name}.json"
        files[name].write_text(json.dumps(doc))
    for args, needle in ((["--friction", str(files["other"])], "device"),
                         (["--friction", str(files["negative"])], "coulomb_motor[2]"),
                         (["--stiffness", "1,2,3,4"], "--stiffness"),
                         (["--half-width", "0.02"], "--half-width"),
                         (["--friction", str(tmp_path / "none.json")], "not found")):
        assert main(["maps", "lexos", *args]) == 2
        err = capsys.readouterr().err
        assert needle in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err


def test_maps_over_the_grid_are_finite_and_the_reference_pose_is_on_it(tmp_path):
    for dev in _devices(tmp_path):
        maps = handle_maps(dev, budget=200)
        d = maps.to_dict()
        u = maps.usable
        assert u.sum() > 0 and np.all(np.isfinite(maps.mass[u])) and np.all(maps.mass[u] > 0)
        assert np.all(maps.dry_min[u] <= maps.dry_max[u] + 1e-12)
        assert d["grid"]["usable"] == int(u.sum())
        fig = maps.plot()
        assert len(fig.axes) >= 4
        assert "apparent mass" in maps.table()


def test_maps_from_values_identified_on_the_lexos_twin(tmp_path, capsys):
    """The chain a lab runs: simulate → identify (PARAMS.json) and identify-friction (FRICTION.json) → maps. The
    identified inertia gives the device file's apparent masses within 10 % at the reference pose; the maps carry
    the identified friction (not the file's)."""
    from tendyn.cli import main

    logs = []
    for t in (1, 2, 3, 4):
        logs.append(str(tmp_path / f"t{t}.parquet"))
        assert main(["simulate", "lexos", "constant-velocity", "--transmission", str(t), "--strategy", "S2",
                     "--speeds", "2,4,6,8,10", "--out", logs[-1], "--quiet"]) == 0
    assert main(["simulate", "lexos", "exciting", "--out", str(tmp_path / "ex.parquet"), "--quiet"]) == 0
    fr, params = tmp_path / "friction.json", tmp_path / "params.json"
    assert main(["identify-friction", "lexos", *logs, "--out", str(fr)]) == 0
    assert main(["identify", "lexos", str(tmp_path / "ex.parquet"), "--out", str(params), "--quiet",
                 "--scheduler", "none"]) == 0
    capsys.readouterr()
    assert main(["maps", "lexos", "--points", "4", "--json"]) == 0
    ref = json.loads(capsys.readouterr().out)
    assert main(["maps", "lexos", str(params), "--friction", str(fr), "--points", "4", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["coulomb_motor_N_m"] == json.loads(fr.read_text())["coulomb_motor"]
    assert doc["mass_not_positive_definite_poses"] == 0
    np.testing.assert_allclose(doc["reference_pose"]["apparent_mass_kg"], ref["reference_pose"]["apparent_mass_kg"],
                               rtol=0.1)
