"""Issue 40: the classic desktop haptic arm (three capstan [[drives]], parallelogram elbow on a closed-loop tree)
through the S0 chain, on generated arms of random dimensions (tendyn.devices.generate.parallelogram_arm_toml).
Each step is checked by an independent route: the statics against finite differences of the potential energy
(virtual work), the plans against every tree joint's limits, the identified friction against the file's."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np
import pytest

from tendyn.device import compile_device
from tendyn.device.schema import DeviceError
from tendyn.devices import load
from tendyn.devices.generate import write_parallelogram_arm

SEEDS = (0, 1, 2)


def _arm(tmp_path, **kw):
    return load(str(write_parallelogram_arm(tmp_path, **kw)))


@pytest.mark.parametrize("seed", SEEDS)
def test_loop_closes_and_gravity_is_virtual_work(tmp_path, seed):
    """Loop closure at random poses; Lᵀ g_tree (the active-joint gravity torques, S2 eq. 12) equals ∂V/∂q_a by
    central differences of the potential energy V(q_a) = −Σ m g·c (Pinocchio's energy, not its rnea)."""
    import pinocchio as pin

    from tendyn.device.closed_loop import loop_closure_error

    dev = _arm(tmp_path, seed=seed)
    comp = compile_device(dev)
    L, c = comp.active_map
    pm = comp.pinocchio_model
    pd = pm.createData()
    rng = np.random.default_rng(seed)
    for _ in range(5):
        qa = rng.uniform([-0.8, -0.4, 0.8], [0.8, 0.8, 1.4])
        assert np.abs(loop_closure_error(dev, qa)).max() < 1e-12
        g_active = L.T @ pin.computeGeneralizedGravity(pm, pd, L @ qa + c)
        h = 1e-6
        fd = [(pin.computePotentialEnergy(pm, pd, L @ (qa + h * e) + c)
               - pin.computePotentialEnergy(pm, pd, L @ (qa - h * e) + c)) / (2 * h) for e in np.eye(3)]
        assert np.allclose(g_active, fd, atol=1e-7), (g_active, fd)
        assert abs(g_active[0]) < 1e-12           # axis 1 vertical: no gravity torque on the base


def test_handle_is_the_end_of_the_forearm(tmp_path):
    from tendyn.device.closed_loop import end_effector_point
    from tendyn.device.rigid_body import tree_joint_numbers

    dev = _arm(tmp_path, seed=3)
    k, point = end_effector_point(dev)
    assert tree_joint_numbers(dev)[k] == 4 and np.allclose(point, 0.0)   # the gimbal frame, d = l2 past the elbow


@pytest.mark.parametrize("kw, words", [
    (dict(loop_gap=0.015), ["kinematics.constraints", "does not close", "15 mm"]),
    (dict(rotor_inertia=10.8), ["drives[1].motor.rotor_inertia", "g·cm²"]),
])
def test_unit_and_closure_mistakes_are_refused(tmp_path, kw, words):
    with pytest.raises(DeviceError) as e:
        _arm(tmp_path, **kw)
    for w in words:
        assert w in str(e.value)


@pytest.mark.parametrize("edit, words", [
    (lambda t: t.replace("upper = 1.0\n", "upper = 57.0\n", 1), ["upper", "degrees?"]),
    (lambda t: re.sub(r"ratio = ([0-9.]+)", lambda m: f"ratio = {1.0 / float(m.group(1))!r}", t, count=1),
     ["drives[1].ratio", "inverted?"]),
])
def test_degrees_and_inverted_ratio_are_refused(tmp_path, edit, words):
    from tendyn.devices.generate import parallelogram_arm_toml

    p = tmp_path / "bad.toml"
    p.write_text(edit(parallelogram_arm_toml(seed=0)), encoding="utf-8")
    with pytest.raises(DeviceError) as e:
        load(str(p))
    for w in words:
        assert w in str(e.value)


def test_transmissions_on_a_tree_are_refused_with_the_way_to_write_it(tmp_path):
    from tendyn.devices.generate import parallelogram_arm_toml

    head = parallelogram_arm_toml(seed=0).split("[[drives]]")[0]
    tx = "".join(f"""[[transmissions]]
joint = {j}
motor_radius = 0.01
driven_radius = 0.1
pretension = 20.0
friction = [{', '.join(['{tau0 = 0.5, nu = 5.0}'] * j)}]
[transmissions.motor]
torque_constant = 0.02
rotor_inertia = 1e-6
continuous_torque = 0.03
peak_torque = 0.2
[transmissions.sensors]
encoder_counts = 4096
current_noise = 0.01
""" for j in (1, 2, 5))
    p = tmp_path / "tx.toml"
    p.write_text(head + tx, encoding="utf-8")
    with pytest.raises(DeviceError, match=r"write its capstans as \[\[drives\]\]"):
        load(str(p))


@pytest.mark.parametrize("seed", SEEDS)
def test_every_plan_stays_inside_every_tree_limit(tmp_path, seed):
    """Each drive's planned test (poses, strokes and the moves between poses) keeps every tree joint — the
    passive elbow, rod and cut joint included — inside its limits: checked on the references themselves."""
    from tendyn.protocols import motor_from_joint, plan_test, references
    from tendyn.sim.experiments import tree_limits

    dev = _arm(tmp_path, seed=seed)
    lo, hi, L, c = tree_limits(dev)
    G = motor_from_joint(dev)
    assert np.allclose(G, np.diag(np.diag(G))) and np.all(np.diag(G) > 1)
    for t in (1, 2, 3):
        test = plan_test(dev, t)
        q, _, space = references(G, test, 0.01)
        assert space == "joint"
        qt = q @ L.T + c
        assert np.all(qt >= lo - 1e-9) and np.all(qt <= hi + 1e-9), (t, qt.min(0), qt.max(0))
        assert np.ptp(q[:, t - 1]) * G[t - 1, t - 1] >= 0.98 * test.travel     # the stroke is all there


def test_identify_friction_of_the_elbow_drive_recovers_the_file(tmp_path):
    """The parallelogram's drive (row 5, drive 3): the twin's planned constant-velocity log, fitted per drive
    (S0 §III-A, :class:`tendyn.ident.friction.TransmissionFriction`), gives the file's Coulomb friction within
    10 % and its viscous friction within 25 % (its %σ is 5–20 %). ~4 s: one twin run of the planned test."""
    from tendyn.ident.friction import TransmissionFriction
    from tendyn.protocols import plan_test
    from tendyn.sim.experiments import constant_velocity

    dev = _arm(tmp_path, seed=0)
    log = constant_velocity(dev, test=plan_test(dev, 3), seed=3).log
    fit = TransmissionFriction(3).fit([log]).result_
    d = dev.drives[2]
    assert abs(fit.coulomb_motor / d.coulomb_motor - 1) < 0.10, fit.coulomb_motor
    assert abs(fit.viscous_motor / d.viscous_motor - 1) < 0.25, fit.viscous_motor


def test_identify_friction_of_every_drive(tmp_path):
    """The three drives through `identify_friction` (the command's function): FRICTION.json per drive."""
    from tendyn.commands.s0 import identify_friction
    from tendyn.protocols import plan_test
    from tendyn.sim.experiments import constant_velocity

    dev = _arm(tmp_path, seed=0)
    logs = [constant_velocity(dev, test=plan_test(dev, t), seed=t).log for t in (1, 2, 3)]
    doc = identify_friction(dev, logs)
    for k, d in enumerate(dev.drives):
        assert abs(doc["coulomb_motor"][k] / d.coulomb_motor - 1) < 0.10, (k, doc["coulomb_motor"][k])
        assert abs(doc["viscous_motor"][k] / d.viscous_motor - 1) < 0.25, (k, doc["viscous_motor"][k])


def _cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "tendyn.cli", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=600)


def test_cli_plan_and_decompose_take_drives(tmp_path):
    """`plan constant-velocity` and `decompose` on a drives file: exit 0, no 'has no cable transmissions'."""
    arm = write_parallelogram_arm(tmp_path, seed=1)
    r = _cli("plan", "constant-velocity", arm, "--transmission", "3", "--out", tmp_path / "ref.csv", "--json",
             cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["transmission"] == 3
    dev = load(str(arm))
    doc = {"format": "tendyn.friction/1", "device": dev.name, "n_transmissions": 3,
           "coulomb_motor": [d.coulomb_motor for d in dev.drives], "viscous_motor": [d.viscous_motor for d in dev.drives]}
    from tendyn.ident.decomposition import drive_split

    out = drive_split(dev, doc)
    assert [r["joint"] for r in out["drives"]] == [1, 2, 5]
    assert np.isclose(out["drives"][2]["coulomb_joint"], dev.drives[2].ratio * dev.drives[2].coulomb_motor)


def test_pipeline_s2_on_a_generated_arm(tmp_path):
    """`pipeline s2 --quick` on an arm that is not the CEA branch: every base parameter, no internal error."""
    arm = write_parallelogram_arm(tmp_path, seed=0)
    r = _cli("pipeline", "s2", arm, "--quick", "--json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    doc = json.loads(r.stdout)
    assert doc["parameters"] == "every base parameter of the device" and doc["table4"] == []
