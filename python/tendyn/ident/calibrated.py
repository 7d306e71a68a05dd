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
    losses : the identified loss model (:class:`IdentifiedLosses`), or None: the file's losses (or friction that
        this routing cannot decompose: :attr:`losses_problem`)
    friction : the identified friction as the motor saw it (FRICTION.json's ``coulomb_motor`` [N·m],
        ``viscous_motor`` [N·m·s/rad], ``load_coefficient`` [-] per transmission, the document read once), or None
    params : the identified base parameters (the PARAMS.json document, read once, checked against this device and
        its file's version), or None
    sources : term → "file" or "identified: <document>" (loss terms of ``LOSS_TERMS``, ``friction``, ``params``,
        and ``stiffness_motor[k]`` per capstan drive k, 1-based)
    losses_problem : why identified friction gives no per-branch loss model (a routing S0 cannot separate), or None
    """

    compiled: CompiledDevice
    losses: IdentifiedLosses | None = None
    params: Any = None
    sources: Mapping[str, str] = field(default_factory=dict)
    friction: Mapping | None = None
    losses_problem: str | None = None
    force: bool = False

    @property
    def device(self):
        """The device description (with the identified capstan stiffness, if any)."""
        return self.compiled.device

    @property
    def name(self) -> str:
        return self.compiled.name

    def loss_model(self) -> IdentifiedLosses | None:
        """The identified loss model, None for the file's; :class:`CalibrationError` when identified friction is
        there but this routing cannot split it over the branches (a differential: FRICTION.json's values are
        the motors', no per-branch model reproduces them)."""
        if self.losses_problem is not None:
            raise CalibrationError(self.losses_problem)
        return self.losses

    def transmission(self):
        """The transmission with the one loss model: the identified one, else the file's (cables, or capstan
        drives as one-branch transmissions: :func:`tendyn.device.compiled.device_transmission`)."""
        losses = self.loss_model()
        if losses is not None:
            return losses.transmission(self.device)
        return device_transmission(self.compiled)

    def identified_model(self):
        """The identified base parameters as an :class:`tendyn.ident.identified.IdentifiedModel` (predict and score
        logs), built from the document read once; None without parameters."""
        if self.params is None:
            return None
        from .identified import IdentifiedModel

        return IdentifiedModel.from_document(self.params, device=self.compiled, force=self.force,
                                            source=self.sources["params"].split(": ", 1)[-1])

    def friction_source(self) -> str:
        """Where the friction comes from: ``file`` or ``identified: <document>``."""
        return self.sources.get("friction", FILE)


def unwrap(device, friction=None):
    """(device, friction) for a consumer that takes either a calibrated device or a device and its friction: a
    :class:`CalibratedDevice` gives its compiled device and its loss model (None: the file's; CalibrationError when
    its friction cannot be split over this routing's branches), unless ``friction`` is given; anything else is
    returned as it is."""
    if isinstance(device, CalibratedDevice):
        return device.compiled, device.loss_model() if friction is None else friction
    return device, friction


def _origin(doc) -> str:
    return Path(doc).name if isinstance(doc, (str, Path)) else "mapping"


def _read(doc, what: str):
    """A JSON document (path → its object, read once; a mapping as it is) and its origin."""
    if not isinstance(doc, (str, Path)):
        return doc, "mapping"
    from .loss_model import _read as read_document

    try:
        return read_document(doc)
    except LossModelError as exc:
        raise CalibrationError(f"{exc} ({what})") from None


def calibrate(device, friction=None, params=None, stiffness=None, shares=None, *, force: bool | None = None,
              physical: bool = False) -> CalibratedDevice:
    """The device file with the identified documents laid over it, per term, with each value's source.

    Parameters
    ----------
    device : Device, CompiledDevice or an already calibrated device (returned as is when nothing is given)
    friction : FRICTION.json (path or dict), ``decompose --json``, per-branch arrays or an
        :class:`IdentifiedLosses` (:func:`tendyn.ident.loss_model.identified_losses`); None: the file's losses.
        A path is read once.
    params : PARAMS.json (path or its document) or an :class:`tendyn.ident.identified.IdentifiedModel`; None: none.
        A path is read once.
    stiffness : identified capstan stiffness K_T [N·m/rad] per drive (motor side), a sequence in the drives'
        order; None: the file's
    shares : (p, p') or a ``tendyn.shares/1`` file for decomposing FRICTION.json (default: the device's)
    force : take documents that name another device, or parameters identified on another version of its file
        (False: a command with ``--force``, whose refusals name it; None: without)
    physical : check FRICTION.json as a reader of its motor-side values does (``decompose``, ``maps``:
        :func:`tendyn.ident.friction_file.validate_friction` with ``physical``, negative values named as not
        physical) before the loss model's own checks (which name them as injecting energy)

    Raises
    ------
    CalibrationError
        a document of another device or file version (unless ``force``), a count that does not fit, a stiffness
        not finite and > 0, friction out of its domain.
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
    losses, motor, problem = None, None, None
    sources["friction"] = FILE
    if friction is not None:
        losses, motor, problem, origin = _friction(compiled, friction, shares, force, physical)
        sources["friction"] = f"identified: {origin}"
        if losses is not None:
            sources.update({t: (f"identified: {losses.origin}" if s == "identified" else s)
                            for t, s in losses.sources.items()})
    doc = None
    if params is not None:
        doc, origin = _params(compiled, params, force)
        sources["params"] = f"identified: {origin}"
    return CalibratedDevice(compiled, losses, doc, MappingProxyType(sources),
                            None if motor is None else MappingProxyType(motor), problem, bool(force))


def _friction(compiled, friction, shares, force, physical):
    """(losses, motor-side values, problem, origin) of identified friction, its document read once."""
    from tendyn.device.routing_checks import NotSeparable

    from .friction_file import FORMAT, FrictionFileError, validate_friction

    if isinstance(friction, IdentifiedLosses):
        try:
            return identified_losses(compiled, friction), None, None, friction.origin
        except LossModelError as exc:
            raise CalibrationError(str(exc)) from None
    doc, origin = _read(friction, "friction")
    motor = None
    if isinstance(doc, Mapping) and doc.get("format") == FORMAT:
        if physical:
            try:
                validate_friction(doc, device=compiled.device, source=None if origin == "mapping" else origin,
                                  physical=True, force=force)
            except FrictionFileError as exc:
                raise CalibrationError(str(exc)) from None
        if force:
            doc = {**doc, "device": compiled.name}
        motor = {k: doc.get(k) for k in ("coulomb_motor", "viscous_motor", "load_coefficient")
                 if doc.get(k) is not None}
        motor["format"], motor["origin"] = FORMAT, origin
    try:
        losses = identified_losses(compiled, doc, shares, origin=origin)
    except NotSeparable as exc:
        if motor is None:
            raise CalibrationError(str(exc)) from None
        return None, motor, (f"{origin}: {exc}; its values are the motors' (the maps take them as they are), "
                             "no per-branch loss model reproduces them"), origin
    except LossModelError as exc:
        raise CalibrationError(str(exc)) from None
    return losses, motor, None, origin


def _params(compiled, params, force):
    """(the PARAMS document, its origin), read once and checked against the device and its file's version."""
    from .identified import IdentifiedModel, device_digest

    if isinstance(params, IdentifiedModel):
        doc, origin = params.to_dict(), "model"
    else:
        doc, origin = _read(params, "params")
    if isinstance(doc, list):           # the list of parameters alone (read_params takes it too)
        doc = {"params": doc}
    if not isinstance(doc, Mapping) or "params" not in doc:
        raise CalibrationError(f"{origin}: params: missing (expected the document of `tendyn identify --out`)")
    named = doc.get("device")
    if named is not None and not force and not compiled.device.is_named(named):
        raise CalibrationError(f"{origin}: device: the parameters are about {named!r}, not {compiled.name!r}"
                               + (" (--force to use them anyway)" if force is False else ""))
    want, have = doc.get("device_sha256"), device_digest(compiled.device)
    if want and have and want != have and not force:
        raise CalibrationError(f"{origin}: device_sha256: identified on another version of {compiled.name}'s "
                               f"file (SHA-256 {want[:12]}… in the document, {have[:12]}… now"
                               + ("; --force to use them anyway)" if force is False else ")"))
    return MappingProxyType(dict(doc)), origin
