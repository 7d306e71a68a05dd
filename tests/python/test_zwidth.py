"""Z-width of the rendered wall on the twin (`tendyn zwidth`, tendyn.pipelines.zwidth): the stability criterion,
Colgate's sampled-data passivity bound against the twin, the passivity controller, the command."""

import json
import subprocess
import sys

import numpy as np
import pytest

from tendyn.control import Compensator, dissipation_bound
from tendyn.device import compile_device, load_device
from tendyn.devices import bundled
from tendyn.pipelines.zwidth import is_stable, reflected_damping, run_zwidth, zwidth_point


@pytest.fixture(scope="module")
def lexos():
    return compile_device(load_device(bundled("lexos")))


def test_stability_criterion_on_known_traces():
    """Independent of the twin: a decaying oscillation is stable, a sustained one (limit cycle) and a growing
    one (energy growth) are not, a resting contact is stable."""
    t = np.linspace(0.0, 0.6, 600)
    tol = 1e-4
    assert is_stable(1e-3 * np.exp(-t / 0.03) * np.sin(2 * np.pi * 40 * t), tol)[0]
    assert not is_stable(1e-3 * np.sin(2 * np.pi * 40 * t), tol)[0]                   # limit cycle
    growing = 1e-6 * np.exp(t / 0.2) * np.sin(2 * np.pi * 40 * t)
    assert np.ptp(growing[400:]) < tol and not is_stable(growing, tol)[0]              # growth below tol
    assert is_stable(np.full_like(t, -2e-4), tol)[0]


def test_reflected_damping_is_the_least_damped_motion_along_the_normal(lexos):
    """Oracle by constrained minimisation (scipy SLSQP) of q̇ᵀ B_q q̇ with J_z q̇ = 1, B_q from the motor
    viscous bound through the transmission, J from Pinocchio (not the core chain)."""
    import pinocchio as pin
    from scipy.optimize import minimize

    from tendyn.control.compensator import end_effector_point

    from tendyn.pipelines.s0_compensation import hand_task

    _, viscous = dissipation_bound(lexos, margin=1.0)
    task = hand_task(lexos)
    q0, normal = task.q0, task.wall_normal
    b = reflected_damping(lexos, viscous, q0=q0, normal=normal)
    joint, point = end_effector_point(lexos)
    model = pin.Model(lexos.pinocchio_model)
    frame = model.addFrame(pin.Frame("h", joint + 1, 0, pin.SE3(np.eye(3), point), pin.FrameType.OP_FRAME))
    data = model.createData()
    pin.computeJointJacobians(model, data, q0)
    pin.updateFramePlacements(model, data)
    jz = normal @ pin.getFrameJacobian(model, data, frame, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)[:3]
    R = np.array(lexos.transmission.model.joint_from_motor_position)
    Bq = np.linalg.inv(R).T @ np.diag(viscous) @ np.linalg.inv(R)
    res = minimize(lambda x: x @ Bq @ x, jz / (jz @ jz), jac=lambda x: 2 * Bq @ x,
                   constraints=[{"type": "eq", "fun": lambda x: jz @ x - 1.0, "jac": lambda x: jz}],
                   method="SLSQP", options={"ftol": 1e-14, "maxiter": 500})
    assert b == pytest.approx(res.fun, rel=1e-5)


@pytest.fixture(scope="module")
def grid(lexos):
    return run_zwidth(lexos, stiffness=[1000.0, 3000.0, 20000.0, 1.0e6], damping=[0.0, 2.0, 15.0],
                      scheduler="none", progress=False)


def test_colgate_passive_region_is_stable_on_the_twin(grid):
    """Colgate's b > K T / 2 + |B| is sufficient: every grid point inside each mode's passive region is stable on
    the twin; the twin finds unstable points outside it (so the criterion can fail)."""
    inside = 0
    for r in grid.rows:
        if r["K"] < grid.colgate_max_stiffness(r["mode"], r["B"]):
            inside += 1
            assert r["stable"], r
    assert inside >= 6
    assert any(not r["stable"] for r in grid.rows if r["mode"] == "compensated")
    assert grid.colgate_b["gravity"] > grid.colgate_b["passivity"] >= grid.colgate_b["compensated"] > 0


def test_unstable_points_give_the_hand_energy_or_keep_oscillating(grid):
    """The criterion's verdict agrees with the twin's energy: every unstable point oscillates above the tolerance
    or grows, every stable point gives the (constant-force) hand no energy in the last third of the run."""
    for r in grid.rows:
        if r["stable"]:
            assert r["energy_to_hand_last"] <= 1e-6 and r["oscillation"] <= 1e-4, r
        else:
            assert r["oscillation"] > 1e-5, r


def test_passivity_controller_restores_the_wall_of_an_over_compensating_compensator(lexos):
    """k = 1.2: a 100 kN/m wall that the k = 0.9 compensator renders stably limit-cycles; with the passivity
    controller it is stable again."""
    text = Compensator.from_device(lexos, underestimation=1.2).text()
    bad = zwidth_point(lexos, 1.0e5, 0.0, compensator_text=text, mode="compensated")
    good = zwidth_point(lexos, 1.0e5, 0.0, compensator_text=text, mode="passivity")
    assert not bad["stable"] and good["stable"], (bad, good)
    assert bad["oscillation"] > 1e-4 and good["oscillation"] <= 1e-4


def test_zwidth_result_serialises_and_plots(grid):
    from matplotlib.figure import Figure

    doc = json.loads(json.dumps(grid.to_dict()))
    assert set(doc["summary"]) == {"gravity", "compensated", "passivity"}
    assert len(doc["rows"]) == 3 * 4 * 3 and "criterion" in doc
    fig = grid.plot()
    assert isinstance(fig, Figure) and len(fig.axes) == 3
    assert "Colgate" in grid.table()


def _tendyn(*args):
    return subprocess.run([sys.executable, "-m", "tendyn.cli", "zwidth", *args], capture_output=True, text=True)


def test_zwidth_cli_on_a_local_dask_cluster(tmp_path, lexos):
    """The command with a compensator file, a tiny grid on the default local Dask cluster: JSON, table, figure."""
    comp = tmp_path / "k12.comp"
    Compensator.from_device(lexos, underestimation=1.2).export(comp)
    out = _tendyn("lexos", "--compensator", str(comp), "--stiffness", "1000:100000:2", "--damping", "0:0:1",
                  "--modes", "compensated,passivity", "--out", str(tmp_path / "zw.parquet"), "--json", "--quiet")
    assert out.returncode == 0, out.stderr
    doc = json.loads(out.stdout)
    assert doc["scheduler"].startswith("local")
    for suffix in (".parquet", ".png", ".html", ".json"):      # the table, figure, page and document beside it
        assert (tmp_path / f"zw{suffix}").exists(), suffix
    assert doc["report"] == str(tmp_path / "zw.html") and "Z-width" in (tmp_path / "zw.html").read_text()
    by = {(r["mode"], r["K"]): r["stable"] for r in doc["rows"]}
    assert by[("compensated", 100000.0)] is False and by[("passivity", 100000.0)] is True


@pytest.mark.parametrize("argv,problem", [
    (["--stiffness", "5:1:3"], "--stiffness"),
    (["--damping", "-1:2:3"], "--damping"),
    (["--modes", "gravity,fast"], "--modes"),
    (["--out", "x.csv"], "--out"),
    (["--compensator", "/nonexistent.comp"], "--compensator"),
])
def test_zwidth_cli_usage_errors(argv, problem):
    out = _tendyn("lexos", "--scheduler", "none", *argv)
    assert out.returncode == 2 and problem in out.stderr and out.stderr.count("\n") == 1, out.stderr


def test_zwidth_cli_refuses_another_devices_compensator_and_a_device_without_cables(tmp_path, lexos):
    path = tmp_path / "lexos.comp"
    Compensator.from_device(lexos).export(path)
    twin = tmp_path / "twin.toml"      # the same arm under another name: another device
    twin.write_text(bundled("lexos").read_text().replace('name = "L-EXOS"', 'name = "L-EXOS copy"', 1))
    out = _tendyn(str(twin), "--compensator", str(path), "--scheduler", "none")
    assert out.returncode == 2 and "--compensator" in out.stderr and "device" in out.stderr
    out = _tendyn("mcgill_bench", "--scheduler", "none")
    assert out.returncode == 2 and "cable" in out.stderr
