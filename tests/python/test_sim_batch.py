"""Batches of simulator runs (tendyn.sim.model.run_batch, C++ tendyn::run_batch): a batch spread over
threads equals the same runs one after the other, bit for bit; bad batches are refused."""

import numpy as np
import pytest

from tendyn import _core
from tendyn.device import compile_device, load_device
from tendyn.devices import bundled
from tendyn.sim.model import LOG_FIELDS, run_batch, run_log, sim_model

STEPS, LOG_EVERY = 3000, 10


@pytest.fixture(scope="module")
def lexos():
    return compile_device(load_device(bundled("lexos")))


def friction_draw(compiled, scale: float) -> _core.SimModel:
    """The L-EXOS twin with every branch's tau0 and beta scaled (one Monte Carlo draw of the friction)."""
    m = sim_model(compiled, rate_hz=10_000.0)
    arrays = {name: np.array(getattr(m.tendon, name)) for name in ("motor_radius", "K", "driven_radius",
                                                                     "reducer_ratio", "reducer_efficiency",
                                                                     "pretension", "tau0", "nu", "beta")}
    arrays["tau0"] = arrays["tau0"] * scale
    arrays["beta"] = arrays["beta"] * scale
    m.tendon = _core.TransmissionModel(arrays)
    m.finalize()
    return m


def inputs(k: int, na: int = 4):
    t = np.arange(STEPS) * 1e-4
    ff = np.column_stack([(0.1 + 0.03 * k) * np.sin(2 * np.pi * (0.7 + 0.2 * i + 0.1 * k) * t) for i in range(na)])
    z = np.zeros_like(ff)
    return z, z, ff, z


def test_batch_equals_sequential_runs_bit_for_bit(lexos):
    """Monte Carlo over the friction: 5 models, 5 inputs, 2 and 3 threads (and 1) against run_log one by one."""
    scales = [0.5, 0.8, 1.0, 1.3, 2.0]
    models = [friction_draw(lexos, s) for s in scales]
    q0s = [np.array([0.0, 0.3, 0.0, 0.8]) + 0.05 * k for k in range(len(models))]
    seq = []
    for k, m in enumerate(models):
        d = _core.SimData(m)
        d.reset(q0s[k], 100 + k)
        log = run_log(m, d, *inputs(k), LOG_EVERY)
        seq.append((log, np.array(d.q), np.array(d.qd), d.dissipated))
    # the draws differ, so equality below is not trivial
    assert not np.array_equal(seq[0][0]["q_joint"], seq[4][0]["q_joint"])
    ins = [np.stack([inputs(k)[c] for k in range(len(models))]) for c in range(4)]
    for threads in (1, 2, 3):
        datas = [_core.SimData(m) for m in models]
        for k, d in enumerate(datas):
            d.reset(q0s[k], 100 + k)
        out = run_batch(models, datas, *ins, LOG_EVERY, threads=threads)
        assert out["threads"] == threads
        for k in range(len(models)):
            for name in LOG_FIELDS:
                assert np.array_equal(out[name][k], seq[k][0][name]), (threads, k, name)
            assert np.array_equal(datas[k].q, seq[k][1]) and np.array_equal(datas[k].qd, seq[k][2])
            assert datas[k].dissipated == seq[k][3]


def test_batch_shared_model_and_inputs(lexos):
    """One model and one input for every run (a sweep over the initial state and the sensor noise seed)."""
    m = sim_model(lexos, rate_hz=10_000.0)
    q0s = [np.array([0.1 * k, 0.3, 0.0, 0.8]) for k in range(4)]
    datas = [_core.SimData(m) for _ in q0s]
    for k, d in enumerate(datas):
        d.reset(q0s[k], k)
    out = run_batch(m, datas, *inputs(0), LOG_EVERY, threads=2)
    for k in range(4):
        d = _core.SimData(m)
        d.reset(q0s[k], k)
        log = run_log(m, d, *inputs(0), LOG_EVERY)
        for name in LOG_FIELDS:
            assert np.array_equal(out[name][k], log[name]), (k, name)
    assert not np.array_equal(out["torque_motor_meas"][0], out["torque_motor_meas"][1])  # seeds differ


def test_batch_refuses_bad_batches(lexos):
    m = sim_model(lexos, rate_hz=10_000.0)
    d = _core.SimData(m)
    d.reset(np.zeros(4), 0)
    z = np.zeros((100, 4))
    with pytest.raises(ValueError, match="its own SimData"):
        run_batch(m, [d, d], z, z, z, z, LOG_EVERY)
    with pytest.raises(ValueError, match="no runs"):
        run_batch(m, [], z, z, z, z, LOG_EVERY)
    with pytest.raises(ValueError, match="inputs must be"):
        run_batch(m, [d], np.zeros((2, 100, 4)), z, z, z, LOG_EVERY)
    with pytest.raises(ValueError, match="log_every"):
        run_batch(m, [d], z, z, z, z, 7)
    m2 = sim_model(lexos, rate_hz=10_000.0)
    m2.coulomb_joint = np.full(4, 0.1)  # 4 more friction sites
    m2.finalize()
    other = _core.SimData(m2)
    with pytest.raises(ValueError, match="not made for its model"):
        run_batch(m, [other], z, z, z, z, LOG_EVERY)
    bad = z.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match="run 0"):
        run_batch(m, [d], z, z, bad, z, LOG_EVERY)
