"""A FRICTION.json from a campaign of constant-velocity logs (S0 §IV-B, issue 8): the logs grouped per
transmission, each transmission fitted (:class:`tendyn.ident.friction.TransmissionFriction`), and the residual-error
bound of each fit computed from the identified values themselves, decomposed with the device's default shares
(S0 eqs. 18–21, :func:`tendyn.ident.decomposition.decompose`). The command ``identify-friction`` parses and calls
:func:`identify_friction`; the grouping and the decomposition live here, with the other loss physics."""

from __future__ import annotations

import numpy as np

from tendyn.protocols import MIN_SPEEDS

from .decomposition import decompose
from .friction import (IdentificationError, TransmissionFriction, log_strategy, log_transmission,
                       residual_error_bound)
from .friction_file import friction_document

__all__ = ["FrictionCampaignError", "group_by_transmission", "identify_friction"]


class FrictionCampaignError(ValueError):
    """A campaign that cannot give a FRICTION.json: a log of a transmission the device lacks, a transmission
    without a log, logs of different strategies for one transmission, or a fit that fails (named by its logs)."""


def group_by_transmission(device, logs, names) -> dict[int, list]:
    """The logs (with their names) per transmission number 1…n (:func:`tendyn.ident.friction.log_transmission`).

    Raises
    ------
    FrictionCampaignError
        a log of a transmission outside 1…n, or a transmission without a log."""
    n = device.n_transmissions or len(device.drives)
    groups: dict[int, list] = {}
    for name, log in zip(names, logs):
        t = log_transmission(log)
        if not 1 <= t <= n:
            raise FrictionCampaignError(f"{name}: transmission {t}, the device has 1…{n}")
        groups.setdefault(t, []).append((name, log))
    missing = [t for t in range(1, n + 1) if t not in groups]
    if missing:
        raise FrictionCampaignError(f"no constant-velocity log for transmission {', '.join(map(str, missing))} "
                                    f"(FRICTION.json needs every transmission 1…{n})")
    return groups


def identify_friction(device, logs, gravity: str = "pairs", min_speeds: int | None = None, names=None,
                      load: str = "auto") -> dict:
    """Fit every transmission from ``logs`` (:class:`tendyn.io.Log`), attach the residual-error bounds [N·m]
    computed from the identified values (decomposed with the default shares; capstan drives have one cable
    stretch each and no bound) and return the FRICTION.json document (docs/friction-file.md).

    Raises
    ------
    FrictionCampaignError
        see :func:`group_by_transmission`; logs of several strategies for one transmission; a fit that fails."""
    names = names or [f"log {k + 1}" for k in range(len(logs))]
    groups = group_by_transmission(device, logs, names)
    fits = []
    for t in sorted(groups):
        strategies = {log_strategy(lg) for _, lg in groups[t]}
        if len(strategies) > 1:
            raise FrictionCampaignError(
                f"transmission {t}: logs of different strategies ({', '.join(sorted(str(s) for s in strategies))}); "
                "give one strategy per transmission")
        est = TransmissionFriction(t, gravity=gravity, device=device if gravity != "pairs" else None,
                                   min_speeds=MIN_SPEEDS if min_speeds is None else min_speeds, load=load)
        try:
            est.fit([lg for _, lg in groups[t]])
        except IdentificationError as exc:
            raise FrictionCampaignError(f"{', '.join(nm for nm, _ in groups[t])}: {exc}") from None
        fits.append(est.result_)
    if not device.n_transmissions:   # capstan drives: one cable stretch per drive, no branches to bound
        return friction_document(device.name, fits)
    c0 = np.array([f.coulomb_motor for f in fits])
    nu = np.array([f.viscous_motor for f in fits])
    dec = decompose(device, np.maximum(c0, 0.0), np.maximum(nu, 0.0))
    arr = device.routing_arrays()
    for f in fits:
        if f.strategy in ("S1", "S2"):
            f.residual_bound = residual_error_bound(arr["K"], arr["motor_radius"], f.transmission - 1, f.strategy,
                                                    dec.tau0_branch, dec.nu_branch, max(f.speeds_motor))
    return friction_document(device.name, fits)
