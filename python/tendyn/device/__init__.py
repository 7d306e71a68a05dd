"""Device descriptions: the TOML device file (schema version 1), its validation and data model, and the
one step from a description to its computing models (:func:`compile_device`).

>>> from tendyn.device import load_device
>>> from tendyn.devices import bundled
>>> dev = load_device(bundled("lexos"))
>>> dev.kind, dev.n_joints
('serial', 4)

Every device kind derives from :class:`Device` (``kind``, ``name``, ``path``, ``experiments``): a
:class:`SerialDevice` (chains and trees with cable transmissions or capstan drives) or a
:class:`TendonBench` (the S1 2N bench). See ``docs/device-file.md`` for the format. The loaders use only
the standard library and numpy; ``rigid_body``, ``closed_loop`` and ``compiled`` use Pinocchio and the core.
"""

from .base import EXPERIMENTS, Device
from .compiled import CompiledDevice, compile_device
from .load import load_device
from .schema import (
    SCHEMA_VERSION,
    Bearing,
    BranchFriction,
    Constraint,
    DeviceError,
    Actuator,
    Drive,
    FieldSpec,
    JointSpec,
    Kinematics,
    Motor,
    Sensors,
    SerialDevice,
    TransmissionSpec,
)
from .tendon_bench import TendonBench

__all__ = [
    "EXPERIMENTS",
    "SCHEMA_VERSION",
    "Bearing",
    "BranchFriction",
    "CompiledDevice",
    "Constraint",
    "Device",
    "DeviceError",
    "Actuator",
    "Drive",
    "FieldSpec",
    "JointSpec",
    "Kinematics",
    "Motor",
    "Sensors",
    "SerialDevice",
    "TendonBench",
    "TransmissionSpec",
    "compile_device",
    "load_device",
]
