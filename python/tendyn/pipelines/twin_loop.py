"""One control period of a simulated device, as a controller in a loop sees it: reset the twin at a pose, read its
quantised motor encoders, run one period with the motor torques held (the Fig. 7 hand runs of
:mod:`tendyn.pipelines.s0_compensation` and the friction-tracking runs of :mod:`tendyn.pipelines.tracking`)."""

from __future__ import annotations

import numpy as np

from tendyn import _core

__all__ = ["ControlBlock", "encoder_step", "encoders", "reset_at"]


def reset_at(sim, data, q0, seed) -> None:
    """Reset the twin at rest at q0 with the (slaved) motor positions set, so the first encoder reading is
    already the pose's (``SimData.reset`` leaves them at zero until the first step)."""
    data.reset(q0, seed)
    data.set_motor_position(np.asarray(sim.Gm) @ q0)   # cables: R_m⁻¹ K q; capstan drives: N q (springs relaxed)


def encoder_step(sim) -> np.ndarray:
    """Resolution of each motor encoder [rad]: 2π / counts per turn, 0 where the twin reads the exact position."""
    counts = np.array(sim.encoder_counts, float)
    return np.where(counts > 0, 2 * np.pi / np.where(counts > 0, counts, 1.0), 0.0)


def encoders(sim, data, step=None) -> np.ndarray:
    """Quantised motor encoder readings [rad] (the simulator's own rule, S0: position sensors only): the motor
    position rounded to the nearest multiple of the encoder's resolution ``step`` [rad] (:func:`encoder_step`,
    computed here when not given; a loop passes it once: :meth:`ControlBlock.encoders`)."""
    step = encoder_step(sim) if step is None else step
    qm = np.array(data.q_motor)
    exact = step <= 0
    return np.where(exact, qm, step * np.floor(qm / np.where(exact, 1.0, step) + 0.5))


class ControlBlock:
    """One control period of the twin in one core call (tendyn._core.run), inputs held over the period."""

    def __init__(self, sim):
        dec, na = sim.control_decimation, sim.na
        self.sim, self.dec = sim, dec
        self.step = encoder_step(sim)           # per loop, not per period (~15 µs a period: issue 39)
        self.zeros = np.zeros((dec, na))
        self.ff = np.zeros((dec, na))
        self.ext = np.zeros((dec, na))
        self.time = np.empty(1)
        self.log = [np.empty((1, na)) for _ in range(7)]

    def encoders(self, data) -> np.ndarray:
        """The motor encoders of ``data`` now [rad] (:func:`encoders`)."""
        return encoders(self.sim, data, self.step)

    def run(self, data, torque_motor, torque_ext) -> None:
        self.ff[:] = torque_motor
        self.ext[:] = torque_ext
        _core.run(self.sim, data, self.zeros, self.zeros, self.ff, self.ext, self.dec, self.time, *self.log)
