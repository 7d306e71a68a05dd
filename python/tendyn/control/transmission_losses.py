"""The device's transmission with one loss model, its file's or the identified one (S0 §IV-B): what the compensator
and the passivity controller's dissipation bound both read, in one place (neither imports the other for it)."""

from __future__ import annotations

from tendyn.device import CompiledDevice, Device, compile_device
from tendyn.device.compiled import device_transmission  # noqa: F401 — its home is the compiled device
from tendyn.transmission import Transmission

__all__ = ["device_transmission", "transmission_with_friction"]


def transmission_with_friction(device: Device | CompiledDevice, friction=None, shares=None) -> Transmission:
    """The device's transmission with one loss model: its own (``friction=None``) or the identified one.

    Identified friction (FRICTION.json, a decomposition, or per-branch arrays: see
    :func:`tendyn.ident.loss_model.identified_losses`) *replaces* every loss term of the device file —
    bearings, β, τ0, ν and the reducer efficiency — since friction identified at the motor already contains
    them all (one loss model at a time; stacking both over-compensates and makes a haptic device active).

    Raises
    ------
    ValueError
        (:class:`tendyn.ident.loss_model.LossModelError`) a file of another device or transmission count, or
        a negative or non-finite value, naming the source and field.
    """
    from tendyn.ident.calibrated import unwrap

    device, friction = unwrap(device, friction)     # a calibrated device: its one loss model
    compiled = compile_device(device)
    if friction is None:
        return device_transmission(compiled)
    from tendyn.ident.loss_model import identified_losses

    return identified_losses(compiled, friction, shares).transmission(compiled.device)

