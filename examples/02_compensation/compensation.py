"""Example 02 in Python: the same compensation cycles as compensation.c / .cpp, on the same model file.

    python compensation.py MODEL.comp [DEVICE_NAME]          # run (n from the file)
    python compensation.py --export DEVICE.toml OUT.comp      # export a device's compensator (any device)
    python compensation.py --export                           # re-export lexos.comp from the bundled lexos.toml

(tests/python/test_examples.py checks that the committed lexos.comp is what Python exports today.)
"""

import math
import sys
from pathlib import Path

import numpy as np

from tendyn.control import Compensator

HERE = Path(__file__).resolve().parent


def export(device_path: str | None, out) -> None:
    from tendyn.device import load_device
    from tendyn.devices import bundled

    Compensator.from_device(load_device(device_path or bundled("lexos"))).export(out)


def main(argv):
    if argv[1:2] == ["--export"] and len(argv) in (2, 4):
        export(*(argv[2:4] if len(argv) == 4 else (None, HERE / "lexos.comp")))
        return 0
    if len(argv) not in (2, 3) or argv[1].startswith("--"):
        print(__doc__, file=sys.stderr)
        return 2
    comp = Compensator.load(argv[1], expected_device=argv[2] if len(argv) > 2 else None)
    torque_joint = 0.5 * (-0.4) ** np.arange(comp.n)
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
