"""The control loop's view of the twin (tendyn.pipelines.twin_loop): what a Python controller reads from the motor
encoders is what the simulator's own controller reads (sim_control.hpp quantises them in C++: the oracle)."""

import numpy as np

from tendyn import _core
from tendyn.device import compile_device, load_device
from tendyn.devices import bundled
from tendyn.pipelines.twin_loop import ControlBlock, encoder_step, encoders, reset_at
from tendyn.sim.model import sim_model


def test_loop_encoders_are_the_simulators_quantised_motor_positions():
    """Over 200 control periods of a driven L-EXOS twin: ControlBlock.encoders (the resolution computed once) and
    encoders() read, before each period, exactly the quantised motor positions the simulator's C++ control step
    logs for that period (q_motor_meas), and they differ from the exact positions by at most half a count."""
    compiled = compile_device(load_device(bundled("lexos")))
    sim = sim_model(compiled, rate_hz=10_000.0, control_hz=1_000.0)
    data = _core.SimData(sim)
    reset_at(sim, data, np.array([0.1, -0.2, 0.3, 0.4]), seed=3)
    block = ControlBlock(sim)
    step = encoder_step(sim)
    assert np.all(step > 0) and np.allclose(step, 2 * np.pi / np.asarray(sim.encoder_counts))
    quantised = 0
    for k in range(200):
        read = block.encoders(data)
        assert np.array_equal(read, encoders(sim, data))
        exact = np.array(data.q_motor)
        assert np.all(np.abs(read - exact) <= 0.5 * step + 1e-15)
        quantised += int(np.any(read != exact))
        block.run(data, 0.05 * np.sin(0.05 * k + np.arange(4)), np.zeros(4))
        np.testing.assert_array_equal(block.log[0][0], read)       # the C++ controller's reading this period
    assert quantised > 150
