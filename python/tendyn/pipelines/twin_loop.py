"""One control period of a simulated device, as a controller in a loop sees it: reset the twin at a pose, read its
quantised motor encoders, run one period with the motor torques held (the Fig. 7 hand runs of
:mod:`tendyn.pipelines.s0_compensation` and the friction-tracking runs of :mod:`tendyn.pipelines.tracking`)."""

from __future__ import annotations

import numpy as np

from tendyn import _core

__all__ = ["ControlBlock", "encoders", "reset_at"]


def reset_at(sim, data, q0, seed) -> None:
    """Reset the twin at rest at q0 with the (slaved) motor positions set, so the first encoder reading is
    already the pose's (``SimData.reset`` leaves them at zero until the first step)."""
    data.reset(q0, seed)
    data.set_motor_position(np.asarray(sim.Gm) @ q0)   # cables: R_m⁻¹ K q; capstan drives: N q (springs relaxed)


def encoders(sim, data) -> np.ndarray:
    """Quantised motor encoder readings [rad] (the simulator's own rule, S0: position sensors only)."""
    qm = np.array(data.q_motor)
    counts = np.array(sim.encoder_counts)
    step = np.where(counts > 0, 2 * np.pi / np.where(counts > 0, counts, 1), 0.0)
    return np.where(step > 0, step * np.floor(qm / np.where(step > 0, step, 1) + 0.5), qm)


class ControlBlock:
    """One control period of the twin in one core call (tendyn._core.run), inputs held over the period."""

    def __init__(self, sim):
        dec, na = sim.control_decimation, sim.na
        self.sim, self.dec = sim, dec
        self.zeros = np.zeros((dec, na))
        self.ff = np.zeros((dec, na))
        self.ext = np.zeros((dec, na))
        self.time = np.empty(1)
        self.log = [np.empty((1, na)) for _ in range(7)]

    def run(self, data, torque_motor, torque_ext) -> None:
        self.ff[:] = torque_motor
        self.ext[:] = torque_ext
        _core.run(self.sim, data, self.zeros, self.zeros, self.ff, self.ext, self.dec, self.time, *self.log)
