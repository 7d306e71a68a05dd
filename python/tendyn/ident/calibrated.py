"""A calibrated device (issue 33 item 1): the device file with the identified values laid over it, per term,
each with its source recorded, in one immutable object every consumer takes (no consumer re-reads or
re-decomposes a document).

The one-loss-model rule lives here: identified friction (FRICTION.json, a decomposition or per-branch arrays)
replaces *every* loss term of the file (:func:`tendyn.ident.loss_model.identified_losses`, S0 §IV-B), never
stacked on it. Identified base parameters (PARAMS.json) are kept as their :class:`IdentifiedModel`; an identified
capstan stiffness K_T [N·m/rad] (motor side, S2 eq. 19) replaces the file's per drive.

>>> from tendyn.devices import load
>>> cal = calibrate(load("lexos"))
>>> cal.sources["tau0"]
'file'
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from tendyn.device import CompiledDevice, compile_device
from tendyn.device.compiled import as_device, device_transmission

from .loss_model import LOSS_TERMS, IdentifiedLosses, LossModelError, identified_losses

__all__ = ["CalibratedDevice", "CalibrationError", "calibrate", "unwrap"]

FILE = "file"
"""The source of a value the device file gives (no identified document replaces it)."""


class CalibrationError(ValueError):
    """An identified document that cannot calibrate this device: another device, a wrong count, a value out of
    its domain (one line naming the document and field)."""


@dataclass(frozen=True, eq=False)
class CalibratedDevice:
    """The device with its identified values (read-only).

    Attributes
    ----------
    compiled : the compiled device, the file's values with the identified capstan stiffness laid over them
    losses : the identified loss model (:class:`IdentifiedLosses`), or None: the file's losses
    params : the identified base parameters (:class:`tendyn.ident.identified.IdentifiedModel`), or None
    sources : term → "file" or "identified: <document>" (loss terms of ``LOSS_TERMS``, ``params``, and
        ``stiffness_motor[k]`` per capstan drive k, 1-based)
    """

    compiled: CompiledDevice
    losses: IdentifiedLosses | None = None
    params: Any = None
    sources: Mapping[str, str] = field(default_factory=dict)

    @property
    def device(self):
        """The device description (with the identified capstan stiffness, if any)."""
        return self.compiled.device

    @property
    def name(self) -> str:
        return self.compiled.name

    def transmission(self):
        """The transmission with the one loss model: the identified one, else the file's (cables, or capstan
        drives as one-branch transmissions: :func:`tendyn.device.compiled.device_transmission`)."""
        if self.losses is not None:
            return self.losses.transmission(self.device)
        return device_transmission(self.compiled)


def unwrap(device, friction=None):
    """(device, friction) for a consumer that takes either a calibrated device or a device and its friction: a
    :class:`CalibratedDevice` gives its compiled device and its loss model (None: the file's), unless
    ``friction`` is given; anything else is returned as it is."""
    if isinstance(device, CalibratedDevice):
        return device.compiled, device.losses if friction is None else friction
    return device, friction


def _origin(doc) -> str:
    return Path(doc).name if isinstance(doc, (str, Path)) else "mapping"


def calibrate(device, friction=None, params=None, stiffness=None, shares=None) -> CalibratedDevice:
    """The device file with the identified documents laid over it, per term, with each value's source.

    Parameters
    ----------
    device : Device, CompiledDevice or an already calibrated device (returned as is when nothing is given)
    friction : FRICTION.json (path or dict), ``decompose --json``, per-branch arrays or an
        :class:`IdentifiedLosses` (:func:`tendyn.ident.loss_model.identified_losses`); None: the file's losses
    params : PARAMS.json (path) or an :class:`tendyn.ident.identified.IdentifiedModel`; None: none
    stiffness : identified capstan stiffness K_T [N·m/rad] per drive (motor side), a sequence in the drives'
        order; None: the file's
    shares : (p, p') or a ``tendyn.shares/1`` file for decomposing FRICTION.json (default: the device's)

    Raises
    ------
    CalibrationError
        a document of another device, a count that does not fit, a stiffness not finite and > 0.
    """
    if isinstance(device, CalibratedDevice):
        if friction is None and params is None and stiffness is None:
            return device
        device = device.compiled
    dev = as_device(device)
    sources = {t: FILE for t in LOSS_TERMS}
    if stiffness is not None:
        drives = tuple(getattr(dev, "drives", ()) or ())
        k = np.asarray(stiffness, float).reshape(-1)
        if not drives or k.size != len(drives):
            raise CalibrationError(f"{dev.name}: {k.size} capstan stiffness value(s) for {len(drives)} drive(s) "
                                   "(field stiffness_motor)")
        if not np.all(np.isfinite(k) & (k > 0)):
            raise CalibrationError(f"{dev.name}: a capstan stiffness must be finite and > 0 N·m/rad "
                                   f"(got {k.tolist()}, field stiffness_motor)")
        dev = dataclasses.replace(dev, drives=tuple(dataclasses.replace(d, stiffness_motor=float(v))
                                                    for d, v in zip(drives, k)))
        sources.update({f"stiffness_motor[{i + 1}]": "identified: stiffness" for i in range(k.size)})
    else:
        sources.update({f"stiffness_motor[{i + 1}]": FILE for i in range(len(getattr(dev, "drives", ()) or ()))})
    compiled = compile_device(dev) if dev is not as_device(device) else compile_device(device)
    losses = None
    if friction is not None:
        try:
            losses = identified_losses(compiled, friction, shares)
        except LossModelError as exc:
            raise CalibrationError(str(exc)) from None
        sources.update({t: (f"identified: {losses.origin}" if s == "identified" else s)
                        for t, s in losses.sources.items()})
    model = None
    if params is not None:
        from .identified import IdentifiedModel

        from tendyn.io.params import ParamsError

        try:
            model = params if isinstance(params, IdentifiedModel) else IdentifiedModel.load(params, device=compiled)
        except ParamsError as exc:
            raise CalibrationError(str(exc)) from None
        if model.device.name != compiled.name:
            raise CalibrationError(f"the parameters are about {model.device.name!r}, not {compiled.name!r} "
                                   "(field device)")
        sources["params"] = f"identified: {_origin(params) if not isinstance(params, IdentifiedModel) else 'model'}"
    return CalibratedDevice(compiled, losses, model, MappingProxyType(sources))
