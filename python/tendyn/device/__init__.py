"""Device descriptions: the TOML device file (schema version 1), its validation and data model.

>>> from tendyn.device import load_device
>>> from tendyn.devices import bundled
>>> dev = load_device(bundled("lexos"))
>>> dev.n_joints
4

See ``docs/device-file.md`` for the format. This package uses only the standard library and numpy.
"""

from .load import load_device
from .schema import (
    SCHEMA_VERSION,
    Bearing,
    BranchFriction,
    Device,
    DeviceError,
    FieldSpec,
    JointSpec,
    Kinematics,
    Motor,
    Sensors,
    Transmission,
)

__all__ = [
    "SCHEMA_VERSION",
    "Bearing",
    "BranchFriction",
    "Device",
    "DeviceError",
    "FieldSpec",
    "JointSpec",
    "Kinematics",
    "Motor",
    "Sensors",
    "Transmission",
    "load_device",
]
