"""Issue 40, S0 §IV on the desktop haptic arm: the compensator of capstan [[drives]] on a closed-loop tree
(generated parallelogram arms, tendyn.devices.generate), exported, loaded in C, Fig. 7 and Z-width on the twin.

Independent routes: the chain's gravity at the actuated joints against finite differences of Pinocchio's potential
energy (virtual work), its handle Jacobian against finite differences of its handle position and against
Pinocchio's frame; the C ABI's motor torques against the one-branch law written out from the device file
(C = τ/N + k w (C_m0 sgn q̇_m + ν q̇_m)); the hand's work measured by the twin (never positive: passive)."""

from __future__ import annotations

import ctypes
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import tendyn
from tendyn import _core
from tendyn.control import Compensator, chain_model
from tendyn.device import compile_device
from tendyn.devices import load
from tendyn.devices.generate import write_parallelogram_arm
from tendyn.device.schema import DRIVE_MOTOR_RADIUS

SEEDS = (0, 1, 2)


def _arm(tmp_path, **kw):
    return load(str(write_parallelogram_arm(tmp_path, **kw)))


def _poses(seed, count=4):
    rng = np.random.default_rng(seed)
    return [rng.uniform([-0.8, -0.4, 0.8], [0.8, 0.8, 1.4]) for _ in range(count)]


@pytest.mark.parametrize("seed", SEEDS)
def test_chain_of_the_tree_is_virtual_work(tmp_path, seed):
    """chain.hpp's active map: gravity_active = ∂V/∂q_a (central differences of Pinocchio's potential energy),
    ee_jacobian_active = ∂x/∂q_a (central differences of the chain's own handle position) and x = Pinocchio's
    handle frame. Fails when the map is dropped (gravity of the 7 tree joints, or L not applied)."""
    import pinocchio as pin

    from tendyn.pipelines.s0_compensation import _Handle

    dev = _arm(tmp_path, seed=seed)
    comp = compile_device(dev)
    L, c = comp.active_map
    chain = chain_model(dev)
    assert chain.n == L.shape[0] == 7 and chain.n_active() == 3
    cd = _core.ChainData(chain)
    pm = comp.pinocchio_model
    pd = pm.createData()
    handle = _Handle(comp)
    h = 1e-6
    for qa in _poses(seed):
        _core.chain_active(chain, cd, qa)
        g = np.array(cd.gravity_active)
        fd = [(pin.computePotentialEnergy(pm, pd, L @ (qa + h * e) + c)
               - pin.computePotentialEnergy(pm, pd, L @ (qa - h * e) + c)) / (2 * h) for e in np.eye(3)]
        np.testing.assert_allclose(g, fd, atol=1e-7)
        x, J_pin = handle(qa)
        np.testing.assert_allclose(np.array(cd.ee_position), x, atol=1e-12)
        J = np.array(cd.ee_jacobian_active)
        np.testing.assert_allclose(J, J_pin, atol=1e-12)
        cols = []
        for e in np.eye(3):
            _core.chain_active(chain, cd, qa + h * e)
            xp = np.array(cd.ee_position)
            _core.chain_active(chain, cd, qa - h * e)
            cols.append((xp - np.array(cd.ee_position)) / (2 * h))
        np.testing.assert_allclose(J, np.column_stack(cols), atol=1e-8)


def _c_library():
    path = Path(tendyn.__file__).parent / "lib" / "libtendyn_c.so"
    if not path.exists():
        pytest.skip(f"{path} not installed")
    lib = ctypes.CDLL(str(path))
    vp, dp = ctypes.c_void_p, ctypes.POINTER(ctypes.c_double)
    lib.tendyn_compensator_load.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.POINTER(vp), ctypes.c_char_p,
                                            ctypes.c_ulong]
    lib.tendyn_compensator_load.restype = ctypes.c_int
    lib.tendyn_compensator_size.argtypes = [vp]
    lib.tendyn_compensator_cycle.argtypes = [vp, dp, dp, dp, dp]
    lib.tendyn_compensator_cycle.restype = ctypes.c_int
    lib.tendyn_compensator_state.argtypes = [vp, dp, dp, dp, dp, dp]
    lib.tendyn_compensator_state.restype = ctypes.c_int
    lib.tendyn_compensator_destroy.argtypes = [vp]
    return lib


def _cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "tendyn.cli", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=600)


@pytest.mark.parametrize("seed", (0, 2))
def test_export_compensator_of_capstan_drives_loads_in_c(tmp_path, seed):
    """`tendyn export compensator` on a drives file (identified per-drive friction as one-branch arrays) → the C
    ABI loads it; at rest it commands the lossless gravity torques L^T g / N (Pinocchio), moving it adds
    k w (C_m0 sgn q̇_m + ν q̇_m) per drive with the identified C_m0, ν (S0 eq. 17 with one branch)."""
    import pinocchio as pin

    lib = _c_library()
    arm = write_parallelogram_arm(tmp_path, seed=seed)
    dev = load(str(arm))
    n = len(dev.drives)
    c0 = np.array([d.coulomb_motor for d in dev.drives]) * 1.05      # "identified": not the file's values
    nu = np.array([d.viscous_motor for d in dev.drives]) * 0.9
    fr = tmp_path / "friction.json"
    r = DRIVE_MOTOR_RADIUS     # per-branch arrays at the drive's equivalent motor radius: τ0 = C_m0 / r, ν = ν_m / r²
    fr.write_text(json.dumps({"device": dev.name, "tau0": np.diag(c0 / r).tolist(), "nu": np.diag(nu / r ** 2).tolist()}))
    out = tmp_path / "arm.comp"
    r = _cli("export", "compensator", arm, "--friction", fr, "--out", out, "--json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    k = summary["underestimation"]
    for i, row in enumerate(summary["friction_at_motor"]):            # zero load, motor i alone at 1 and 5 rad/s
        np.testing.assert_allclose(row["friction"], [c0[i] + nu[i] * v for v in row["speeds"]], rtol=1e-12)
    assert "active_map" in out.read_text()

    N = np.array([d.ratio for d in dev.drives])
    comp = compile_device(dev)
    L, c = comp.active_map
    pm = comp.pinocchio_model
    handle, msg = ctypes.c_void_p(), ctypes.create_string_buffer(512)
    assert lib.tendyn_compensator_load(str(out).encode(), dev.name.encode(), ctypes.byref(handle), msg, 512) == 0, \
        msg.value
    as_c = lambda a: a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))  # noqa: E731
    try:
        assert lib.tendyn_compensator_size(handle) == n
        qa = np.array([0.3, 0.2, 1.1])
        g = L.T @ pin.computeGeneralizedGravity(pm, pm.createData(), L @ qa + c)
        tm, zero = np.zeros(n), np.zeros(n)
        qm = np.ascontiguousarray(N * qa)
        assert lib.tendyn_compensator_cycle(handle, as_c(qm), as_c(zero), as_c(tm), None) >= 0
        np.testing.assert_allclose(tm, g / N, rtol=1e-10, atol=1e-14)   # at rest: gravity only, lossless
        speed = np.array([4.0, -6.0, 8.0])                                # [rad/s] at the motors
        for step in range(1, 400):                                        # the 30 Hz filter settles
            qm = np.ascontiguousarray(N * qa + speed * step / 1000.0)
            assert lib.tendyn_compensator_cycle(handle, as_c(qm), as_c(zero), as_c(tm), None) >= 0
        q, qdm, grav = np.zeros(n), np.zeros(n), np.zeros(n)
        assert lib.tendyn_compensator_state(handle, as_c(q), None, as_c(qdm), as_c(grav), None) >= 0
        np.testing.assert_allclose(qdm, speed, rtol=1e-6)
        np.testing.assert_allclose(q, qm / N, rtol=1e-14)
        g = L.T @ pin.computeGeneralizedGravity(pm, pm.createData(), L @ q + c)
        np.testing.assert_allclose(grav, g, rtol=1e-10, atol=1e-14)
        w = np.minimum(1.0, np.abs(qdm) / Compensator.load(out).model.velocity_band)
        expected = g / N + k * w * (c0 * np.sign(qdm) + nu * qdm)
        np.testing.assert_allclose(tm, expected, rtol=1e-9)
    finally:
        lib.tendyn_compensator_destroy(handle)


def test_a_drive_friction_file_is_read_per_drive(tmp_path):
    """FRICTION.json of a drives device (identify-friction's format) → one branch per drive, τ0 = C_m0, ν = ν_m;
    a decomposition or shares are refused (a capstan has nothing to split)."""
    from tendyn.ident.friction import FrictionFit  # noqa: F401  (the format's owner)
    from tendyn.ident.loss_model import LossModelError, identified_losses

    dev = _arm(tmp_path, seed=1)
    c0 = [0.001, 0.002, 0.003]
    nu = [1e-6, 2e-6, 3e-6]
    r = DRIVE_MOTOR_RADIUS
    losses = identified_losses(dev, {"tau0": np.diag(c0) / r, "nu": np.diag(nu) / r ** 2})
    tr = losses.transmission(dev)
    N = np.array([d.ratio for d in dev.drives])
    np.testing.assert_allclose(np.array(tr.model.joint_from_motor_position), np.diag(1.0 / N), rtol=1e-14)
    res = tr.feedforward(np.array([0.5, -0.2, 0.1]), np.array([1.0, -1.0, 0.5]) / N)
    np.testing.assert_allclose(res.torque_motor, np.array([0.5, -0.2, 0.1]) / N
                               + np.array(c0) * [1, -1, 1] + np.array(nu) * [1.0, -1.0, 0.5], rtol=1e-12)
    with pytest.raises(LossModelError, match="nothing to decompose"):
        identified_losses(dev, {"format": "tendyn.decomposition/1", "device": dev.name, "transmissions": []})


def test_fig7_on_a_generated_arm_halves_the_hand_torque_and_stays_passive(tmp_path):
    """S0 Fig. 7 on a parallelogram capstan arm (the file's losses, k = 0.9): the hand's RMS joint-1 torque falls
    by ≥ 50 % and the device does no net work on the hand over the cycle nor over any 0.25 s window
    (passive: the compensator never injects energy). Fails with k = 0 in the compensated run (0 % reduction) or
    with the friction sign flipped (the hand's torque doubles). A short circle (1.5 s) keeps it ~5 s."""
    from tendyn.pipelines.s0_compensation import hand_run

    dev = _arm(tmp_path, seed=0)
    kw = dict(period=1.5, settle=0.3, cycles=1)
    g = hand_run(dev, 0.0, **kw)
    c = hand_run(dev, 0.9, **kw)
    reduction = 1.0 - c.rms_joint1 / g.rms_joint1
    assert reduction >= 0.5, (reduction, g.rms_joint1, c.rms_joint1)
    assert c.energy_to_hand_per_cycle <= 0.0, c.energy_to_hand_per_cycle
    assert np.all(c.energy_windows(0.25) <= 1e-6), c.energy_windows(0.25)


@pytest.mark.slow
@pytest.mark.parametrize("seed", (1, 2))
def test_fig7_on_more_arms(tmp_path, seed):
    """The same on other arms, the S0 circle period (4 s)."""
    from tendyn.pipelines.s0_compensation import fig7_experiment

    res = fig7_experiment(_arm(tmp_path, seed=seed), over=(), walls=False)
    assert res.reduction_joint1 >= 0.5 and res.compensated.energy_to_hand_per_cycle <= 0.0, res.to_dict()


def test_zwidth_runs_on_a_capstan_arm(tmp_path):
    """Two wall designs on the arm in process (a 2 kN/m wall, a light push): gravity-only is stable, the run
    gives the hand no energy in its last third."""
    from tendyn.pipelines.zwidth import run_zwidth

    dev = _arm(tmp_path, seed=0)
    res = run_zwidth(dev, stiffness=[2000.0], damping=[0.0], modes=("gravity", "compensated"), scheduler="none",
                     progress=False, push=0.2)
    assert res.rows[0]["stable"], res.rows
    assert all(r["stable"] or r["oscillation"] > 0 for r in res.rows), res.rows
    assert res.colgate_b["gravity"] > 0


def test_pipeline_s0_on_a_generated_arm(tmp_path):
    """`tendyn pipeline s0 ARM --quick --json`: per-drive identification within 10 % (Coulomb), Fig. 7 ≥ 50 %."""
    arm = write_parallelogram_arm(tmp_path, seed=0)
    r = _cli("pipeline", "s0", arm, "--quick", "--json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    doc = json.loads(r.stdout)
    assert all(abs(t["s2_coulomb_error_pct"]) < 10 for t in doc["transmissions"]), doc["transmissions"]
    assert doc["compensation"]["reduction_joint1"] >= 0.5
    assert doc["compensation"]["energy_to_hand_per_cycle"] <= 0.0
