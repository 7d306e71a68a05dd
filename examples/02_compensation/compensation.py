"""Example 02 in Python: the same compensation cycles as compensation.c / .cpp, on the same model file.

Regenerate the model file with ``python compensation.py --export`` (tests/python/test_examples.py checks that
the committed lexos.comp is what Python exports from the bundled lexos.toml today).
"""

import math
import sys
from pathlib import Path

import numpy as np

from tendyn.control import Compensator

HERE = Path(__file__).resolve().parent


def main(argv):
    if "--export" in argv:
        from tendyn.device import load_device
        from tendyn.devices import bundled

        Compensator.from_device(load_device(bundled("lexos"))).export(HERE / "lexos.comp")
        return 0
    comp = Compensator.load(argv[1] if len(argv) > 1 else HERE / "lexos.comp", expected_device="L-EXOS")
    torque_joint = np.array([0.5, -0.2, 0.1, 0.05])
    total = np.zeros(comp.n)
    worst = 0.0
    for k in range(500):
        t = k / 1000.0
        q_motor = np.array([2.0 * math.sin(2.0 * 3.141592653589793 * (0.5 + 0.3 * i) * t) + 0.1 * i
                            for i in range(comp.n)])
        torque_motor = comp.cycle(q_motor, torque_joint)
        total += torque_motor
        worst = max(worst, comp.data.compute_time)
    print("torque_motor " + " ".join(f"{v:.17g}" for v in torque_motor))
    print("sum_torque_motor " + " ".join(f"{v:.17g}" for v in total))
    print(f"# longest cycle {1e6 * worst:.3g} us")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
