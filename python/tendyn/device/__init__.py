"""Device descriptions: the TOML device file (schema version 1), its validation and data model.

>>> from tendyn.device import load_device
>>> from tendyn.devices import bundled
>>> dev = load_device(bundled("lexos"))
>>> dev.n_joints
4

See ``docs/device-file.md`` for the format. The loader uses only the standard library and numpy;
``rigid_body`` and ``closed_loop`` (rigid-body models, closed-loop maps, base parameters) use Pinocchio.
"""

from .load import load_device
from .schema import (
    SCHEMA_VERSION,
    Bearing,
    BranchFriction,
    Constraint,
    Device,
    DeviceError,
    Drive,
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
    "Constraint",
    "Device",
    "DeviceError",
    "Drive",
    "FieldSpec",
    "JointSpec",
    "Kinematics",
    "Motor",
    "Sensors",
    "Transmission",
    "load_device",
]
