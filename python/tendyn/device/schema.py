"""Device description, schema version 1: the data model and the field specifications.

Two halves:

* **Field specifications** (:class:`FieldSpec`): for every key a device file may hold, its type, unit,
  default and allowed range. :mod:`tendyn.device.load` validates against these tables, and
  ``docs/device-file.md`` documents the same fields (a test checks that every field is documented).
* **Data model**: frozen dataclasses built by :func:`tendyn.device.load_device`. All values are SI and
  radians; joints and transmissions are numbered from 1 in the file and in the ``joint`` / ``crosses``
  attributes, while the numpy arrays of :meth:`Device.routing_arrays` are indexed from 0.

The parts, one job each: :mod:`~tendyn.device.schema_fields` (the field tables),
:mod:`~tendyn.device.schema_parts` (joints, kinematics, transmissions, drives, actuators, terms),
:mod:`~tendyn.device.core_fields` (the core transmission model's fields derived from the tables) and
:mod:`~tendyn.device.serial_device` (:class:`SerialDevice`, the N+1 refusal). This face re-exports their names.

Nothing here imports the compiled core; only the standard library and numpy.
"""

from __future__ import annotations

from .base import Device, DeviceError  # noqa: F401 — DeviceError: its home is base.py (terms, rigid_body raise it)
from .core_fields import (BEARING_ARRAY_NAMES, BEARING_PREFIX, LOSS_FIELD_NAMES, NO_BEARING,  # noqa: F401
                          TRANSMISSION_MODEL_FIELDS, ModelField)
from .schema_fields import (ACTUATOR_FIELDS, ALL_FIELD_TABLES, BEARING_FIELDS, CONSTRAINT_FIELDS,  # noqa: F401
                            CONVENTIONS, DEVICE_FIELDS, DEVICE_KINDS, DH_JOINT_FIELDS, DRIVE_FIELDS,
                            FRICTION_FIELDS, GRAVITY_MAX_NORM, INERTIA_TOL, KINEMATICS_FIELDS, MDH_JOINT_FIELDS,
                            MOTOR_FIELDS, ROUTINGS, SCHEMA_VERSION, SENSOR_FIELDS, TERM_FIELDS, TERM_KINDS,
                            TOP_FIELDS, TRANSMISSION_FIELDS, TWO_PI, FieldSpec)
from .schema_parts import (Actuator, Bearing, BranchFriction, Constraint, Drive, JointSpec,  # noqa: F401
                           Kinematics, Motor, Sensors, Term, TransmissionSpec, inertia_matrix)
from .serial_device import DRIVE_MOTOR_RADIUS, SerialDevice, require_one_per_joint  # noqa: F401
