"""A device compiled once: the one step from a description to its computing models.

:func:`compile_device` turns a loaded :class:`~tendyn.device.base.Device` into a :class:`CompiledDevice`
holding what simulation, identification and compensation compute with: the joint frames, the Pinocchio
model (and a data factory), the C++ rigid-body model, the active-coordinate map q_tree = L q_active + c and
the :class:`tendyn.transmission.Transmission` of the cables. Each part is built on first use and then kept,
and the compiled form is kept per device object, so no experiment, estimator or pipeline derives a model
from the raw description a second time:

>>> from tendyn.device import compile_device, load_device
>>> from tendyn.devices import bundled
>>> dev = load_device(bundled("lexos"))
>>> cd = compile_device(dev)
>>> compile_device(dev) is cd and compile_device(cd) is cd
True
>>> cd.active_map.L.shape
(4, 4)

The parts are shared: treat them as read-only (a Pinocchio *data* is per caller: :meth:`~CompiledDevice.
pinocchio_data`). The simulator model (:func:`tendyn.sim.model.sim_model`) is assembled per run from these
parts, because every experiment sets its own controller on it; assembling it builds nothing from the
description.
"""

from __future__ import annotations

from functools import cached_property
from typing import Any, NamedTuple

import numpy as np

from .base import Device

__all__ = ["ActiveMap", "CompiledDevice", "compile_device", "device_transmission"]

_CACHE_ATTR = "_compiled"


class ActiveMap(NamedTuple):
    """q_tree = L q_active + c (identity and zero for a serial chain, the loop constraints for a closed one).

    L : (n_tree, n_active) [-]; c : (n_tree,) [rad] (or [m] for a prismatic joint).
    """

    L: np.ndarray
    c: np.ndarray


class CompiledDevice:
    """The computing models of one device, built once (see :func:`compile_device`).

    Attributes
    ----------
    device : Device
        The description it was compiled from.
    name, kind, experiments : as ``device``
    joint_frames : list of :class:`tendyn.device.rigid_body.JointFrame`
        The rigid-body tree derived from the kinematic description (serial devices).
    pinocchio_model : pinocchio.Model
        The tree as a Python Pinocchio model (gravity from the device).
    rigid_body : tendyn._core.RigidBodyModel
        The same tree in the C++ core (the simulator copies it).
    active_map : ActiveMap
        (L, c) with q_tree = L q_active + c.
    active_joints : list of int
        0-based tree indices of the active joints.
    transmission : tendyn.transmission.Transmission or None
        The cable transmissions (None for capstan drives and for a tendon bench).

    The serial-only parts raise ValueError on a tendon bench (``kind == "tendon_bench_2n"``), whose
    computing model is the bench model of :mod:`tendyn.sim.tendon_bench`.
    """

    def __init__(self, device: Device):
        if not isinstance(device, Device):
            raise TypeError(f"expected a tendyn.device.Device (got {type(device).__name__})")
        self.device = device

    def __repr__(self) -> str:
        return f"CompiledDevice({self.device.name!r}, kind={self.kind!r})"

    # ---- identity, as the description ---------------------------------------------------------
    @property
    def name(self) -> str:
        return self.device.name

    @property
    def kind(self) -> str:
        return self.device.kind

    @property
    def experiments(self) -> tuple[str, ...]:
        return self.device.experiments

    def _serial(self, what: str):
        if self.kind != "serial":
            raise ValueError(f"{self.name} is a {self.kind} device: it has no {what}")
        return self.device

    # ---- rigid body ---------------------------------------------------------------------------
    @cached_property
    def joint_frames(self) -> list:
        from .rigid_body import joint_frames

        return joint_frames(self._serial("rigid-body tree"))

    @cached_property
    def pinocchio_model(self) -> Any:
        from .rigid_body import pinocchio_model

        return pinocchio_model(self._serial("rigid-body tree"), frames=self.joint_frames)

    def pinocchio_data(self) -> Any:
        """A new ``pinocchio.Data`` of :attr:`pinocchio_model` (one per caller: it is written to)."""
        return self.pinocchio_model.createData()

    @cached_property
    def rigid_body(self) -> Any:
        from .rigid_body import rigid_body_model

        return rigid_body_model(self._serial("rigid-body tree"), frames=self.joint_frames)

    @cached_property
    def terms(self) -> Any:
        """The device's ``[[terms]]`` in active coordinates (:class:`tendyn.device.terms.TermModel`)."""
        from .terms import TermModel

        return TermModel(self)

    # ---- active coordinates -------------------------------------------------------------------
    @cached_property
    def _active(self) -> tuple[list[int], ActiveMap]:
        from .rigid_body import active_coordinate_map

        active, L, c = active_coordinate_map(self._serial("joint coordinates"))
        L, c = np.asarray(L, float), np.asarray(c, float)
        L.flags.writeable = False
        c.flags.writeable = False
        return list(active), ActiveMap(L, c)

    @property
    def active_map(self) -> ActiveMap:
        return self._active[1]

    @property
    def active_joints(self) -> list[int]:
        return list(self._active[0])

    @property
    def n_active(self) -> int:
        return self.active_map.L.shape[1]

    # ---- transmission -------------------------------------------------------------------------
    @cached_property
    def transmission(self) -> Any:
        """The square statics with losses (:class:`tendyn.transmission.Transmission`); None without
        transmissions. An N+1 device raises DeviceError (exit 2): the compensator, identification and the exports
        built on it take one cable per joint (the simulator takes N+1 through :attr:`tendon_model`)."""
        if self.kind != "serial" or not self.device.transmissions:
            return None
        from .schema import require_one_per_joint

        require_one_per_joint(self.device, "the S0 statics with losses (compensator, identification, exports)")
        from tendyn.transmission import Transmission

        return Transmission.from_device(self.device)

    @cached_property
    def tendon_model(self) -> Any:
        """The core's ``TendonModel`` of an N+1 device (K, motor radii, floors, branch losses of S0 eq. 12; wrapped
        by :class:`tendyn.tendons.Tendons`); None otherwise."""
        if not getattr(self.device, "n_plus_one", False):
            return None
        from .routing_checks import tendon_model

        return tendon_model(self.device.transmissions, self.device.n_joints)

    def __getstate__(self):  # the compiled models are rebuilt after unpickling, not pickled
        return {"device": self.device}


def compile_device(device: Device | CompiledDevice) -> CompiledDevice:
    """The compiled form of ``device``, built once per device object.

    Parameters
    ----------
    device : Device or CompiledDevice
        A loaded description (any kind), or an already compiled one (returned as is).

    Returns
    -------
    CompiledDevice
        The same object for every call with the same device object.
    """
    if isinstance(device, CompiledDevice):
        return device
    if not isinstance(device, Device):
        raise TypeError(f"compile_device expects a tendyn.device.Device or CompiledDevice "
                        f"(got {type(device).__name__})")
    compiled = device.__dict__.get(_CACHE_ATTR)
    if compiled is None:
        compiled = CompiledDevice(device)   # N+1: the simulator takes it; .transmission refuses (exit 2)
        object.__setattr__(device, _CACHE_ATTR, compiled)  # devices are frozen; the cache is not a field
    return compiled


def as_device(device: Device | CompiledDevice) -> Device:
    """The description behind a Device or CompiledDevice."""
    return device.device if isinstance(device, CompiledDevice) else device


def device_transmission(device: Device | CompiledDevice) -> Any:
    """The transmission a compensator of ``device`` drives with the device file's losses: its cable
    transmissions, or its capstan ``[[drives]]`` as one-branch transmissions (S0 eq. 17 with one branch:
    C_m = τ/N + C_m0 sgn(q̇_m) + ν_m q̇_m; :meth:`tendyn.device.schema.SerialDevice.drive_routing_arrays`).

    Raises
    ------
    ValueError
        A device with neither (a tendon bench, geared ``[[actuators]]``).
    """
    compiled = compile_device(device)
    if compiled.transmission is not None:
        return compiled.transmission
    dev = compiled.device
    if compiled.kind == "serial" and getattr(dev, "drives", ()):
        from tendyn.transmission import LOSS_FIELDS, Transmission

        a = dev.drive_routing_arrays()
        return Transmission.from_arrays(a["motor_radius"], a["K"], a["reducer_ratio"], a["reducer_efficiency"],
                                        a["pretension"], **{k: a[k] for k in LOSS_FIELDS})
    raise ValueError(f"{compiled.name}: no cable transmissions or capstan drives to compensate")
