"""S0 Fig. 7 on the L-EXOS twin (C11), passivity, the stiff wall, and `tendyn pipeline s0`."""

import json

import numpy as np
import pytest

from tendyn.claims import assert_claim, twins
from tendyn.device import compile_device, load_device
from tendyn.devices import bundled
from tendyn.pipelines.s0_compensation import wall_run


@pytest.fixture(scope="module")
def lexos():
    return compile_device(load_device(bundled("lexos")))


@pytest.fixture(scope="module")
def fig7(claims_ctx):
    """Gravity only, k = 0.9 and k = 1.2 on the L-EXOS twin, seed 7 (tendyn.claims.twins.fig7)."""
    return twins.fig7(claims_ctx)


def test_C11_active_compensation_cuts_the_joint1_hand_torque_by_more_than_half(fig7, claims_ctx):
    """C11: moving the end effector in free motion, the RMS joint-1 torque the hand needs drops by more than 50 %
    with friction compensation (k = 0.9) against gravity compensation alone (fixed seed; our goal ≥ 70 %)."""
    print(fig7.table())
    assert_claim("C11", claims_ctx)


def test_passivity_the_compensated_device_injects_no_net_energy_into_the_hand(fig7):
    """Over a closed cycle the work the device does on the hand is ≤ 0 (within noise) with compensation
    (k < 1); gravity only dissipates more; over-compensation (k = 1.2) does positive work on the hand."""
    tol = 1e-3   # J per cycle
    assert fig7.gravity_only.energy_to_hand_per_cycle < 0
    assert fig7.compensated.energy_to_hand_per_cycle <= tol
    assert fig7.gravity_only.energy_to_hand_per_cycle < fig7.compensated.energy_to_hand_per_cycle
    assert fig7.over[0].energy_to_hand_per_cycle > 10 * tol        # k = 1.2 injects energy


def test_fig7_result_plots_and_serialises(fig7):
    from matplotlib.figure import Figure

    fig = fig7.plot()
    assert isinstance(fig, Figure) and len(fig.axes[0].lines) >= 2
    d = fig7.to_dict()
    json.dumps(d)
    assert 0 < d["reduction_joint1"] < 1 and d["rms_joint1_gravity_only"] > d["rms_joint1_compensated"]
    assert "reduction [%]" in fig7.table()


def test_stiff_virtual_wall_settles_without_a_limit_cycle(lexos):
    """A 3000 N/m wall rendered through the compensator (k = 0.9): the hand presses in and the contact settles
    (peak-to-peak height over the last 0.5 s below 0.2 mm), the proxy on the surface."""
    w = wall_run(lexos, 0.9, duration=1.5, seed=7)
    assert not w.limit_cycle, w.oscillation
    assert np.mean(w.height[-200:]) < 0            # pressed into the wall
    assert np.all(w.force[-200:, 2] > 0)           # in contact at the end, pushing out


def test_over_compensation_makes_the_wall_oscillate(lexos):
    """Over-compensation (k = 1.2 > 1) feeds energy in: the same wall keeps a limit cycle."""
    w = wall_run(lexos, 1.2, duration=1.5, seed=7)
    assert w.limit_cycle and w.oscillation > 1e-3, w.oscillation


def test_pipeline_s0_command_json(tmp_path, s0_quick_run, capsys, monkeypatch):
    """`tendyn pipeline s0 --quick --json --report DIR` prints the contract keys and writes the figures; the run is
    the session's (conftest.py: the same `run_s0(lexos, quick=True)` the command calls; the README walk-through runs
    the command itself in a process of its own)."""
    import tendyn.pipelines.s0
    from tendyn.cli import main

    monkeypatch.setattr(tendyn.pipelines.s0, "run_s0", s0_quick_run)
    assert main(["pipeline", "s0", "--quick", "--json", "--report", str(tmp_path / "rep")]) == 0
    doc = json.loads(capsys.readouterr().out)
    for key in ("transmissions", "decomposition", "compensation"):
        assert key in doc
    comp = doc["compensation"]
    for key in ("reduction_joint1", "rms_joint1_gravity_only", "rms_joint1_compensated", "energy_to_hand_per_cycle"):
        assert isinstance(comp[key], float)
    assert 0.5 < comp["reduction_joint1"] < 1
    assert (tmp_path / "rep" / "fig7_compensation.png").exists() and (tmp_path / "rep" / "s0.json").exists()
    # issue 17 item 4: with the identified losses (load term included) the reduction reaches 70 %, passively
    assert comp["underestimation"] == 0.9 and comp["reduction_joint1"] >= 0.70, comp
    assert comp["energy_to_hand_per_cycle"] < 0.0, comp
    assert doc["identification"]["decomposition_max_relative_mismatch"] < 1e-9


def test_C11_identified_losses_with_the_load_term_reach_70_percent_and_keep_the_wall(lexos):
    """Issue 17 item 4 (C7, C9, C11, C46): S2 on the twin's logs identifies C_m0, ν and the load term c_L; the
    compensator built from them (one loss model: the twin's β and η_d replaced, never added) cuts the joint-1
    hand torque by ≥ 70 % at k = 0.9, injects no energy into the hand, and the stiff wall settles. The same logs
    fitted with S0's load-free law (c_L = 0: τ̂0 absorbs the load the test carried) make the same compensator
    active at k = 0.9 — why the load term is needed."""
    from tendyn.ident.friction import TransmissionFriction
    from tendyn.ident.friction_file import friction_document
    from tendyn.pipelines.s0_compensation import fig7_experiment
    from tendyn.pipelines.s0_friction import compare_strategies

    _, runs = compare_strategies(lexos.device, keep_runs=True)
    logs = {t: runs[(t, "S2")].log for t in range(1, 5)}
    docs = {mode: friction_document(lexos.name, [TransmissionFriction(t, load=mode).fit(logs[t]).result_
                                                 for t in range(1, 5)]) for mode in ("auto", "none")}
    assert "load_coefficient" in docs["auto"] and "load_coefficient" not in docs["none"]
    d = fig7_experiment(lexos, friction=docs["auto"], underestimation=0.9, over=(), walls=True).to_dict()
    assert d["reduction_joint1"] >= 0.70 and d["energy_to_hand_per_cycle"] < 0.0, d
    assert not d["wall"][0]["limit_cycle"], d["wall"]
    s0_law = fig7_experiment(lexos, friction=docs["none"], underestimation=0.9, over=(), walls=False).to_dict()
    assert s0_law["energy_to_hand_per_cycle"] > 0.0, s0_law
