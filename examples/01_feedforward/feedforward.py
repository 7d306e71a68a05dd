"""Example 01 (Python): L-EXOS feedforward motor torques with cable losses, from the bundled device file.
Same inputs and output format as feedforward.c and feedforward.cpp."""

from tendyn.device import load_device
from tendyn.devices import bundled
from tendyn.transmission import Transmission

tr = Transmission.from_device(load_device(bundled("lexos")))
res = tr.feedforward([2.0, 0.0, 0.0, 1.0], qd=[0.5, 0.0, 0.0, 0.2])  # N·m wanted, rad/s now
print("torque_motor " + " ".join(f"{v:.17g}" for v in res.torque_motor))
