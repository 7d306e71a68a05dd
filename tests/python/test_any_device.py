"""A lab's own cable device, end to end (issue 17, items 1, 2, 4 and 5; C7, C9, C10, C11): every S0 command on
device files the tests generate (1, 2, 3 and 6 transmissions, planar and spatial, with and without bearings), each
stage handing over to the next through its file — plan → simulate → identify-friction → decompose → export →
the C/C++ loader — never by hand."""

import json

import numpy as np
import pytest

from tendyn.devices.generate import write_cable_device
from tendyn.cli import main
from tendyn.control import Compensator
from tendyn.device import load_device
from tendyn.io import read_log

CASES = [pytest.param((6, True, False), id="n6-planar"),
         pytest.param((6, False, True), id="n6-spatial-bearings", marks=pytest.mark.slow),
         pytest.param((3, False, True), id="n3-spatial-bearings"),
         pytest.param((2, True, True), id="n2-planar-bearings"),
         pytest.param((1, True, False), id="n1-planar")]
"""(transmissions, planar, bearings) of the chains; the largest first (longest-first scheduling of the parallel
run). The six-transmission spatial arm with bearings runs with ``-m slow`` (its chain is ~50 s of CPU): `make test`
runs the same code path on the three-transmission spatial arm with bearings and on the six-transmission planar
arm (tests/python/test_suite_selection.py names the twins)."""

DEMO_CASES = [pytest.param((6, True, False), id="demo-n6-planar", marks=pytest.mark.slow),
              pytest.param((6, False, True), id="demo-n6-spatial-bearings", marks=pytest.mark.slow),
              pytest.param((3, False, True), id="demo-n3-spatial-bearings"),
              pytest.param((2, True, True), id="demo-n2-planar-bearings"),
              pytest.param((1, True, False), id="demo-n1-planar")]
"""The devices of `demo` and `pipeline s0 --quick` (~25 s of CPU on each six-transmission arm: ``-m slow``; the
three-transmission spatial arm with bearings is their twin in `make test`)."""


@pytest.fixture(scope="module", params=CASES)
def chain(request, tmp_path_factory):
    """The S0 chain run through the command line on one generated device: the paths of every stage's file."""
    n, planar, bearings = request.param
    d = tmp_path_factory.mktemp(f"dev{n}")
    dev = write_cable_device(d, n, planar=planar, bearings=bearings, seed=10 + n)
    refs, logs = [], []
    for t in range(1, n + 1):
        # the references as Parquet: the CSV a bench reads is written and read by the README walk-through and
        # test_ident_friction's plan test; here its ~0.3 M rows per transmission only cost time (issue 39)
        ref, log = d / f"ref{t}.parquet", d / f"t{t}.parquet"
        assert main(["plan", "constant-velocity", str(dev), "--transmission", str(t), "--out", str(ref)]) == 0
        assert main(["simulate", str(dev), "constant-velocity", "--transmission", str(t), "--quiet",
                     "--out", str(log)]) == 0
        refs.append(ref)
        logs.append(log)
    friction = d / "friction.json"
    assert main(["identify-friction", str(dev), *map(str, logs), "--out", str(friction)]) == 0
    comp = d / "x.comp"
    assert main(["export", "compensator", str(dev), "--friction", str(friction), "--out", str(comp)]) == 0
    return dict(n=n, dev=dev, refs=refs, logs=logs, friction=friction, comp=comp, folder=d)


def test_plan_and_simulate_make_the_same_test_inside_the_limits(chain):
    """Item 2: what plan writes is what the twin runs with the same defaults; every reference stays inside the
    joint limits and there are two poses wherever gravity changes the load."""
    device = load_device(chain["dev"])
    lims = np.array([[j.lower, j.upper] for j in device.kinematics.joints])
    for ref, log in zip(chain["refs"], chain["logs"]):
        r, lg = read_log(ref), read_log(log)
        assert r.meta["options"]["poses"] == lg.meta["options"]["poses"]
        assert r.meta["options"]["travel_motor"] == lg.meta["options"]["travel_motor"]
        q = r.stack("q_ref_")
        assert np.all(q >= lims[:, 0] - 1e-9) and np.all(q <= lims[:, 1] + 1e-9)
        assert np.all(lg.stack("q_motor_") == lg.stack("q_motor_"))     # finite, the twin ran the whole test


def test_identified_friction_is_near_the_twins_truth(chain):
    """C7 on generated devices: every transmission identified from the logs alone (no truth read); the friction
    at the test's load within 15 % of the twin's at 5 rad/s, plus the S2 residual-error bound of the held distal
    cables that cross its joint (ERRATA eq. 15, computed by identify-friction from the identified values)."""
    from tendyn.pipelines.s0_friction import true_global_at_load, truth_arrays
    from tendyn.io import truth_path

    device = load_device(chain["dev"])
    doc = json.loads(chain["friction"].read_text())
    assert doc["device"] == device.name and doc["n_transmissions"] == chain["n"]
    for t, log in enumerate(chain["logs"], start=1):
        truth = json.loads(truth_path(log).read_text())
        lg = read_log(log)
        opts = lg.meta["options"]
        c0, nu = true_global_at_load(truth_arrays(truth), device, t, np.array(opts["poses"][0]),
                                     opts["travel_motor"], opts["speeds_motor"], route="core")
        fit = doc["fits"][t - 1]
        load = np.mean(np.abs(opts["load_motor"][:1]))
        est = fit["coulomb_motor"] + fit["load_coefficient"] * load + 5.0 * fit["viscous_motor"]
        want = c0 + 5.0 * nu
        assert abs(est - want) <= 0.15 * want + (fit["residual_bound"] or 0.0), (t, fit, c0, nu)


def test_decompose_and_export_hand_over(chain, capsys):
    """Items 3 and 5: decompose reads the FRICTION.json identify-friction wrote, reproducing it (eqs. 18–19, C9);
    the exported compensator loads in the core with every loss term identified or none, for this device only."""
    assert main(["decompose", str(chain["dev"]), str(chain["friction"]), "--json"]) == 0
    dec = json.loads(capsys.readouterr().out)
    assert dec["format"] == "tendyn.decomposition/1" and dec["max_relative_mismatch"] < 1e-9
    device = load_device(chain["dev"])
    comp = Compensator.load(chain["comp"], expected_device=device.name)
    assert comp.n == chain["n"] and "device" not in comp.loss_sources.values()
    with pytest.raises(ValueError, match="expected 'L-EXOS'"):
        Compensator.load(chain["comp"], expected_device="L-EXOS")


@pytest.mark.parametrize("case", DEMO_CASES)
def test_demo_and_pipeline_s0_run(case, tmp_path, capsys):
    """Item 1: demo and pipeline s0 (quick) on the generated device: no L-EXOS constant in the way."""
    n, planar, bearings = case
    dev = write_cable_device(tmp_path, n, planar=planar, bearings=bearings, seed=10 + n)   # the chain's device
    assert main(["demo", str(dev), "--out", str(tmp_path / "demo")]) == 0
    assert (tmp_path / "demo" / "statics_with_losses.png").exists()
    capsys.readouterr()
    rc = main(["pipeline", "s0", str(dev), "--quick", "--json"])
    out = capsys.readouterr().out
    assert rc in (0, 1), out        # 1 = the C11 check (> 50 %) failed on this device: a result, not a crash
    doc = json.loads(out)
    comp = doc["compensation"]
    assert len(doc["transmissions"]) == n
    assert comp["energy_to_hand_per_cycle"] <= 0.0, comp         # passive (C10, C46)
    assert comp["rms_joint1_compensated"] < comp["rms_joint1_gravity_only"], comp
