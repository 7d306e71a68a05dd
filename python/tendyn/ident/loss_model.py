"""One loss model at a time: the transmission losses a compensator (or the statics) uses once friction is
identified.

Friction identified at the motor from constant-velocity tests (S0 eq. 13, corrected: ERRATA, with the load term
of :mod:`tendyn.ident.friction`)

    C_m − C_0 = (C_m0 + c_L |C_0|) sgn(q̇_m) + ν q̇_m        [N·m], C_0 the lossless load torque at the motor

already contains every loss the motor saw: the branch τ0 and ν, the bearings (their pretension part in C_m0,
their load part in c_L), β along the cable and the reducer's efficiency (both in c_L). So the identified terms
*replace* the device file's — never stack on them (a compensator that adds the file's bearings, β and η_d to the
identified τ0 over-compensates and makes a haptic device active). :func:`identified_losses` builds that model:

* τ0, ν per branch from C_m0, ν through the decomposition (S0 eqs. 18–21, corrected: ERRATA; shares p, p');
* bearings: none (contained in τ0 and c_L);
* the load term at the reducer: η_d = 1 / (1 + c_L). In both directions of power flow this reproduces c_L |C_0|
  exactly: driving, C_0/η_d − C_0 = c_L C_0; back-driven, C_0 η_i − C_0 = −c_L C_0 with η_i = (2η_d − 1)/η_d
  = 1 − c_L (S0 eq. 10). Constant-velocity tests at the motor cannot tell β along the cable from the reducer:
  both scale with the same cable tension, so their sum is identified and placed where it is exact;
* β: none (in c_L).

The result records the source of every term (``identified`` or ``none``), which the compensator model file
keeps (``section losses``, include/tendyn/compensator_file.hpp), and whose core check refuses a model that
mixes identified and device-file terms.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import numpy as np

from tendyn.results import Result, format_table
from tendyn.io.files import read_json

__all__ = ["LOSS_TERMS", "IdentifiedLosses", "LossModelError", "identified_losses"]

LOSS_TERMS = ("tau0", "nu", "beta", "bearings", "reducer_efficiency")
"""The loss terms whose source a compensator records (the order of ``CompensatorModel.loss_source``)."""

DECOMPOSITION_FORMAT = "tendyn.decomposition/1"


class LossModelError(ValueError):
    """Identified friction that cannot make a loss model (another device, a wrong count, a negative or
    non-finite value); ``str(err)`` is ``SOURCE: FIELD: problem``."""

    def __init__(self, problem: str, *, source=None, field: str | None = None):
        self.source, self.field, self.problem = (None if source is None else str(source)), field, problem
        super().__init__(": ".join([p for p in (self.source, field) if p] + [problem]))


@dataclass(eq=False)
class IdentifiedLosses(Result):
    """The per-branch losses of every transmission from identified friction, and their sources.

    Attributes (0-based ``[transmission, branch]``, branch 0 on the base)
    ----------
    device : device name
    tau0 : (n, n) Coulomb force per branch [N]
    nu : (n, n) viscous coefficient per branch [N·s/m]
    beta : (n, n) tension-proportional loss per branch [-] (0 unless given per branch)
    reducer_efficiency : (n,) η_d [-] = 1 / (1 + c_L)
    load_coefficient : (n,) c_L [-], the identified load-dependent loss (0 when not identified)
    sources : {term: "identified" | "none" | "device"} for LOSS_TERMS
    origin : where the friction came from (file name or "mapping")
    decomposition : the :class:`tendyn.ident.decomposition.LossDecomposition` these per-branch values come from
        (FRICTION.json of cable transmissions), or None
    """

    device: str
    tau0: np.ndarray
    nu: np.ndarray
    beta: np.ndarray
    reducer_efficiency: np.ndarray
    load_coefficient: np.ndarray
    sources: dict = field(default_factory=dict)
    origin: str = "mapping"
    decomposition: object = None

    @property
    def n(self) -> int:
        return int(self.tau0.shape[0])

    def source_list(self) -> list[str]:
        """The sources in LOSS_TERMS order (``CompensatorModel.loss_source``)."""
        return [self.sources[t] for t in LOSS_TERMS]

    def transmission(self, device):
        """The device's routing (radii, reducer ratios, pretension) with these losses and no bearings:
        a :class:`tendyn.transmission.Transmission` for the statics or a compensator."""
        from tendyn.transmission import Transmission

        arr = routing_of(device)
        return Transmission.from_arrays(arr["motor_radius"], arr["K"], arr["reducer_ratio"], self.reducer_efficiency,
                                        arr["pretension"], tau0=self.tau0, nu=self.nu, beta=self.beta)

    def to_dict(self) -> dict:
        return {"device": self.device, "origin": self.origin, "sources": dict(self.sources),
                "units": {"tau0": "N", "nu": "N·s/m", "beta": "-", "reducer_efficiency": "-",
                          "load_coefficient": "-"},
                "tau0": self.tau0, "nu": self.nu, "beta": self.beta,
                "reducer_efficiency": self.reducer_efficiency, "load_coefficient": self.load_coefficient}

    def table(self) -> str:
        rows = [(i + 1, float(self.tau0[i].sum()), float(self.nu[i].sum()), float(self.load_coefficient[i]),
                 float(self.reducer_efficiency[i])) for i in range(self.n)]
        head = format_table(("transmission", "Σ τ0 [N]", "Σ ν [N·s/m]", "c_L [-]", "η_d [-]"), rows)
        return (f"{self.device}: identified loss model from {self.origin}\n{head}\nsources: "
                + ", ".join(f"{k} {v}" for k, v in self.sources.items()))

    reading = ('For each transmission, the Coulomb force summed over the branches of its route: the taller the bar, '
               'the more that cable loses.')

    def _draw(self, ax) -> None:
        """Σ τ0 per transmission [N] (bars)."""
        x = np.arange(self.n) + 1
        ax.bar(x, self.tau0.sum(axis=1), color="C0", label="Σ τ0 over the branches")
        ax.set_xlabel("transmission")
        ax.set_ylabel("Coulomb force summed over the branches [N]")
        ax.set_xticks(x)
        ax.legend()


def routing_of(device) -> dict:
    """The routing arrays the loss model applies to: the cable transmissions', or for a device of capstan
    ``[[drives]]`` only, the drives as one-branch transmissions (:meth:`SerialDevice.drive_routing_arrays`)."""
    if not device.transmissions and getattr(device, "drives", ()):
        return device.drive_routing_arrays()
    return device.routing_arrays()


def _count(dev) -> int:
    """Transmissions of the loss model: the cables, or the capstan drives of a device that has no cables."""
    return dev.n_transmissions or len(getattr(dev, "drives", ()) or ())


def _read(friction) -> tuple[Mapping, str]:
    if isinstance(friction, (str, Path)):
        path = Path(friction)
        try:
            return read_json(path), path.name
        except OSError as exc:
            raise LossModelError(f"cannot read: {exc.strerror or exc}", source=path) from None
        except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as exc:
            raise LossModelError(f"not JSON: {exc}", source=path) from None
    if not isinstance(friction, Mapping):
        raise TypeError("friction must be FRICTION.json (path), a decomposition (decompose --json) or a mapping "
                        f"(got {type(friction).__name__})")
    return friction, "mapping"


def _array(doc, key, shape, source, *, nonneg=True, upper=None) -> np.ndarray:
    try:
        a = np.asarray(doc[key], float)
    except (TypeError, ValueError):
        raise LossModelError("must be numbers", source=source, field=key) from None
    if a.shape != shape:
        raise LossModelError(f"must have shape {shape} (got {a.shape})", source=source, field=key)
    bad = ~np.isfinite(a) | ((a < 0) if nonneg else False) | ((a >= upper) if upper is not None else False)
    if np.any(bad):
        idx = tuple(int(i) + 1 for i in np.argwhere(bad)[0])
        value = float(a[tuple(i - 1 for i in idx)])
        rule = "finite and >= 0" + (f" and < {upper}" if upper is not None else "")
        raise LossModelError(f"must be {rule} (got {value!r}): negative friction would inject energy",
                             source=source, field=f"{key}[{','.join(map(str, idx))}]")
    return a


def _reducer_from_load(c_l: np.ndarray, source) -> np.ndarray:
    """η_d = 1/(1 + c_L) (module docstring); c_L ≥ 1 would make the reducer self-locking (η_d ≤ 0.5)."""
    for i, c in enumerate(c_l):
        if not (math.isfinite(c) and 0.0 <= c < 1.0):
            raise LossModelError(f"must be in [0, 1) (got {c!r}): a negative value would inject energy, one "
                                 ">= 1 makes the equivalent reducer self-locking", source=source,
                                 field=f"load_coefficient[{i + 1}]")
    return 1.0 / (1.0 + c_l)


def identified_losses(device, friction, shares=None, origin: str | None = None) -> IdentifiedLosses:
    """The loss model of ``device`` from identified friction, replacing every loss term of its file.

    Parameters
    ----------
    device : a serial cable device (:class:`tendyn.device.SerialDevice` or compiled)
    friction : FRICTION.json (``tendyn.friction/1``: path or its dict), a decomposition (``tendyn decompose
        --json``, ``tendyn.decomposition/1``), or a mapping of per-branch arrays ``tau0`` [N] and ``nu`` [N·s/m]
        (n, n), optionally ``beta`` (n, n) [-], ``reducer_efficiency`` (n,) [-] or ``load_coefficient`` (n,) [-],
        and ``sources`` (a term → "device"/"identified"/"none" mapping; default identified, absent terms none);
        or an :class:`IdentifiedLosses` already built for this device, returned as it is (built once)
    shares : (p, p') (n, n) arrays, or a ``tendyn.shares/1`` file, for the decomposition of FRICTION.json
        (default :func:`tendyn.ident.decomposition.default_shares`)
    origin : the name of the document a mapping was read from (default: ``mapping``, a path's own name)

    Raises
    ------
    LossModelError
        One line naming the source and field: another device, another transmission count, negative or
        non-finite values, a load coefficient outside [0, 1).
    """
    from tendyn.device import compile_device
    from tendyn.ident.friction_file import FORMAT

    dev = compile_device(device).device
    n = _count(dev)
    if n == 0:
        raise LossModelError(f"{dev.name} has no cable transmissions or capstan drives")
    if isinstance(friction, IdentifiedLosses):
        if friction.device != dev.name or np.shape(friction.tau0) != (n, n):
            raise LossModelError(f"the loss model is about {friction.device!r}, not {dev.name!r}", field="device")
        return friction
    doc, read_origin = _read(friction)
    origin = origin or read_origin
    name = doc.get("device")
    if name is not None and name != dev.name:
        raise LossModelError(f"the friction is about {name!r}, not {dev.name!r}", source=origin, field="device")
    fmt = doc.get("format")
    inner = doc.get("branch_losses", doc)
    if fmt == FORMAT:
        parts = _from_friction_file(dev, doc, shares, origin)
    elif fmt == DECOMPOSITION_FORMAT and not dev.transmissions:
        raise LossModelError("capstan drives have one cable stretch each, nothing to decompose: give "
                             "identify-friction's FRICTION.json", source=origin, field="format")
    elif fmt == DECOMPOSITION_FORMAT:
        parts = _from_decomposition(dev, doc, origin)
    elif fmt is None and ("tau0" in inner or "nu" in inner):
        parts = _from_branch_arrays(dev, inner, origin)
    else:
        raise LossModelError(f"unknown friction format {fmt!r} (expected {FORMAT!r}, {DECOMPOSITION_FORMAT!r} "
                             "or per-branch arrays 'tau0', 'nu')", source=origin, field="format")
    tau0_b, nu_b, beta, eta, load, given, *decomposition = parts
    sources = {"tau0": "identified", "nu": "identified", "beta": "none", "bearings": "none",
               "reducer_efficiency": "none"}
    sources.update(given)
    if eta is None and load is not None:
        eta = _reducer_from_load(load, origin)
        sources["reducer_efficiency"] = "identified"
    elif eta is None:
        eta, load = np.ones(n), np.zeros(n)
    elif load is None:
        load = 1.0 / eta - 1.0
    return _finish(dev, tau0_b, nu_b, beta, eta, load, sources, origin, *decomposition)


def _from_friction_file(dev, doc, shares, src):
    """FRICTION.json: C_m0, ν decomposed over the branches (S0 eqs. 20–21), c_L when identified."""
    from tendyn.ident.decomposition import SharesError, decompose, read_shares
    from tendyn.ident.friction_file import FrictionFileError, validate_friction

    n = _count(dev)
    try:
        validate_friction(doc, device=dev, source=None if src == "mapping" else src)
    except FrictionFileError as exc:
        raise LossModelError(str(exc)) from None
    c0 = _array(doc, "coulomb_motor", (n,), src)
    nu = _array(doc, "viscous_motor", (n,), src)
    load = _array(doc, "load_coefficient", (n,), src) if doc.get("load_coefficient") is not None else None
    if not dev.transmissions:   # capstan drives: one branch each at unit motor radius (drive_routing_arrays)
        if shares is not None:
            raise LossModelError("capstan drives have one cable stretch each: shares split nothing", field="shares")
        from tendyn.device.schema import DRIVE_MOTOR_RADIUS as r

        return np.diag(c0 / r), np.diag(nu / r ** 2), np.zeros((n, n)), None, load, {}
    p = pp = None
    if isinstance(shares, (str, Path)):
        try:
            p, pp = read_shares(shares, dev)
        except SharesError as exc:
            raise LossModelError(str(exc)) from None
    elif shares is not None:
        p, pp = (np.asarray(a, float) for a in shares)
    dec = decompose(dev, c0, nu, p, pp, load)      # S0 eqs. 20–21; c_L carried as it is (to the reducer below)
    return dec.tau0_branch, dec.nu_branch, np.zeros((n, n)), None, load, {}, dec


def _from_decomposition(dev, doc, src):
    """``tendyn decompose --json``: the per-branch values as they are, c_L per transmission when given."""
    n = dev.n_transmissions
    rows = doc.get("transmissions")
    if not isinstance(rows, list) or len(rows) != n:
        raise LossModelError(f"must list the {n} transmissions of {dev.name}", source=src, field="transmissions")
    tau0_b, nu_b = np.zeros((n, n)), np.zeros((n, n))
    load = np.zeros(n) if any(isinstance(r, dict) and "load_coefficient" in r for r in rows) else None
    for i, row in enumerate(rows):
        if not isinstance(row, dict):
            raise LossModelError("must be an object", source=src, field=f"transmissions[{i + 1}]")
        nb = dev.transmissions[i].joint
        for key, dst in (("tau0_branch", tau0_b), ("nu_branch", nu_b)):
            dst[i, :nb] = _array({key: row.get(key)}, key, (nb,), src)
        if load is not None:
            load[i] = _array({"load_coefficient": [row.get("load_coefficient", 0.0)]}, "load_coefficient", (1,), src)[0]
    return tau0_b, nu_b, np.zeros((n, n)), None, load, {}


def _from_branch_arrays(dev, inner, src):
    """Per-branch arrays (n, n): ``tau0``, ``nu``, optionally ``beta``, ``reducer_efficiency`` (n,),
    ``load_coefficient`` (n,) and ``sources``; a term not given is absent (none)."""
    n = _count(dev)
    zeros = np.zeros((n, n))
    tau0_b = _array(inner, "tau0", (n, n), src) if "tau0" in inner else zeros
    nu_b = _array(inner, "nu", (n, n), src) if "nu" in inner else zeros
    beta = _array(inner, "beta", (n, n), src, upper=1.0) if "beta" in inner else zeros
    load = _array(inner, "load_coefficient", (n,), src) if "load_coefficient" in inner else None
    eta = None
    if "reducer_efficiency" in inner:
        eta = _array(inner, "reducer_efficiency", (n,), src)
        if np.any((eta <= 0) | (eta > 1)):
            raise LossModelError("must be in (0, 1]", source=src, field="reducer_efficiency")
    given = {term: ("identified" if term in inner else "none") for term in ("tau0", "nu", "beta")}
    if eta is not None:
        given["reducer_efficiency"] = "identified"
    for term, value in inner.get("sources", {}).items():
        if term not in LOSS_TERMS or value not in ("device", "identified", "none"):
            raise LossModelError(f"{term!r}: {value!r} (terms {', '.join(LOSS_TERMS)}; sources device, "
                                 "identified, none)", source=src, field="sources")
        given[term] = value
    return tau0_b, nu_b, beta, eta, load, given


def _finish(dev, tau0, nu, beta, eta, load, sources, origin, decomposition=None) -> IdentifiedLosses:
    n = _count(dev)
    low = np.tril(np.ones((n, n)))
    for key, a in (("tau0", tau0), ("nu", nu), ("beta", beta)):
        if np.any(a * (1 - low) != 0):
            raise LossModelError("values past the driven joint (a cable has i branches)", source=origin, field=key)
    return IdentifiedLosses(dev.name, tau0, nu, beta, np.asarray(eta, float), np.asarray(load, float),
                            sources, origin, decomposition)
