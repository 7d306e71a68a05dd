"""Example 01 (Python): feedforward motor torques with cable losses, for any device.

Usage: ``python feedforward.py MODEL_FILE`` (a model file exported with ``Transmission.export``, or a compensator
model file) or ``python feedforward.py DEVICE.toml`` (the device file itself). Joint i (0-based) wants
τ_i = 2/(i+1) N·m and moves at q̇_i = 0.5/(i+1) rad/s. Same inputs and output as feedforward.c / .cpp.
"""

import sys

import numpy as np

from tendyn.transmission import Transmission


def transmission(path: str) -> Transmission:
    if path.endswith(".toml"):
        from tendyn.device import load_device

        return Transmission.from_device(load_device(path))
    return Transmission.load(path)


def main(argv) -> int:
    if len(argv) != 2:
        print(f"usage: {argv[0]} MODEL_FILE|DEVICE.toml", file=sys.stderr)
        return 2
    tr = transmission(argv[1])
    i = np.arange(tr.n)
    res = tr.feedforward(2.0 / (i + 1), qd=0.5 / (i + 1))  # N·m wanted, rad/s now
    print("torque_motor " + " ".join(f"{v:.17g}" for v in res.torque_motor))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
