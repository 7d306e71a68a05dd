"""The McGill 2N tendon bench (S1) device file: data model and validating loader.

The file (``kind = "tendon_bench_2n"``, see ``tendyn/devices/mcgill_bench.toml``) holds::

    schema = 1
    [device]   name, kind, description
    [bench]    ratio, k1, k2, mass_motor, damping_motor, mass_load, k_z, pretension,
               friction_c0, friction_mu_tension, amplifier_lag, noise_force, noise_position,
               [peak_force]   (optional: the actuator's limit, read by the commands, not simulated)

All values are SI, tendon-linear at the driven-pulley rim, channel-equivalent (the two-mass chain of S1
eq. 2; the simulator splits them over the two motors and tendons). :func:`tendyn.device.load_device`
dispatches here when ``[device].kind == "tendon_bench_2n"``. Only the standard library is used.
"""

from __future__ import annotations

import difflib
import math
import os
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any, ClassVar

from ._toml import read_toml
from tendyn.text import name_problem, text_problem

from ._toml import typename as _typename
from .base import Device
from .schema import DeviceError

__all__ = ["BENCH_FIELDS", "BENCH_MODEL_FIELDS", "BENCH_OPTIONAL", "KIND", "TendonBench", "load_tendon_bench"]

KIND = "tendon_bench_2n"
"""The ``[device].kind`` of a 2N tendon bench file."""

AMPLIFIER_MIN_BANDWIDTH_HZ = 1000.0
"""The amplifier lag must keep a corner frequency of at least this [Hz] (DEVICES.md §2)."""

# name -> (unit, lower bound, lower bound open?, upper bound or None, description)
BENCH_FIELDS: dict[str, tuple[str, float, bool, float | None, str]] = {
    "ratio": ("-", 0.0, True, None, "pulley ratio r"),
    "k1": ("N/m", 0.0, True, None, "proximal tendon stiffness of the channel"),
    "k2": ("N/m", 0.0, True, None, "distal tendon stiffness of the channel"),
    "mass_motor": ("kg", 0.0, True, None, "motor inertia at the rim r^2 I_M"),
    "damping_motor": ("N s/m", 0.0, False, None, "motor damping at the rim r^2 B"),
    "mass_load": ("kg", 0.0, True, None, "load inertia I_c"),
    "k_z": ("N/m", 0.0, False, None, "load stiffness to ground"),
    "pretension": ("N", 0.0, False, None, "tendon pretension T_pre (= amplifier bias)"),
    "friction_c0": ("N", 0.0, False, None, "Coulomb friction per motor node at zero tension F_c0"),
    "friction_mu_tension": ("-", 0.0, False, 1.0, "friction per newton of tension mu_T"),
    "amplifier_lag": ("s", 0.0, False, 1.0 / (2.0 * math.pi * AMPLIFIER_MIN_BANDWIDTH_HZ),
                      "first-order amplifier time constant (0 = ideal current source)"),
    "noise_force": ("N", 0.0, False, None, "sensor noise on F_m, rms"),
    "noise_position": ("m", 0.0, False, None, "sensor noise on X_t, rms"),
    "peak_force": ("N", 0.0, True, None, "largest command force |u| the actuators give at the rim, over the "
                   "pretension bias (optional: no limit declared when absent)"),
}

BENCH_OPTIONAL = ("peak_force",)
"""Fields a file may leave out (``TendonBench`` holds None then). They are the device's limits, read by the
commands (``plan --amplitude``, ``sweep --amplitudes``: :data:`tendyn.commands.args.DEVICE_LIMITS`), not
parameters of the simulated plant, so the C++ ``TENDYN_TENDON_BENCH_FIELDS`` does not mirror them."""

BENCH_MODEL_FIELDS = tuple(k for k in BENCH_FIELDS if k not in BENCH_OPTIONAL)
"""The fields of the simulated plant, in order: the rows of ``TENDYN_TENDON_BENCH_FIELDS`` up to noise_position."""

DEVICE_KEYS = ("name", "kind", "description")
TOP_KEYS = ("schema", "device", "bench")


@dataclass(frozen=True)
class TendonBench(Device):
    """One 2N tendon channel of the McGill bench (S1), channel-equivalent rim values [SI].

    Attributes
    ----------
    kind : str
        ``"tendon_bench_2n"`` (class attribute).
    experiments : tuple of str
        ``("stepped-sine", "swept-sine", "low-speed-loop", "prbs")`` (class attribute).
    name : str
    ratio : float
        Pulley ratio r [-].
    k1, k2 : float
        Proximal / distal stiffness of the channel [N/m]; k_e = k1 k2 / (k1 + k2).
    mass_motor : float
        r² I_M [kg].
    damping_motor : float
        r² B [N·s/m].
    mass_load : float
        I_c [kg].
    k_z : float
        Load stiffness to ground [N/m].
    pretension : float
        T_pre [N] per tendon at rest (also the amplifier bias F_pre).
    friction_c0 : float
        F_c0 [N] per motor node.
    friction_mu_tension : float
        μ_T [-]: node friction F_c = F_c0 + μ_T T.
    amplifier_lag : float
        First-order amplifier time constant [s], 0 = ideal.
    noise_force : float
        Sensor noise on F_m [N rms].
    noise_position : float
        Sensor noise on X_t [m rms].
    peak_force : float or None
        Largest command force |u| [N] the two actuators give at the rim, over the pretension bias (motor A
        pulls F_pre + max(u, 0), S1's class-B split); None: the file declares no limit.
    description : str
    source : str or None
        The file it was read from.
    """

    name: str = "McGill 2N tendon bench"
    ratio: float = 15.0
    k1: float = 2.566e4
    k2: float = 1.0e5
    mass_motor: float = 0.575
    damping_motor: float = 10.8
    mass_load: float = 0.05
    k_z: float = 1.0e9
    pretension: float = 5.0
    friction_c0: float = 0.1
    friction_mu_tension: float = 0.005
    amplifier_lag: float = 0.0
    noise_force: float = 0.0
    noise_position: float = 0.0
    peak_force: float | None = None
    description: str = ""
    source: str | None = None
    kind: ClassVar[str] = KIND
    experiments: ClassVar[tuple[str, ...]] = ("stepped-sine", "swept-sine", "low-speed-loop", "prbs")

    @property
    def path(self) -> Path | None:
        """The file it was read from, or None."""
        return None if self.source is None else Path(self.source)

    @property
    def k_e(self) -> float:
        """k_e = k1 k2 / (k1 + k2) [N/m] (S1 eq. 1)."""
        return self.k1 * self.k2 / (self.k1 + self.k2)

    @property
    def friction_at_rest(self) -> float:
        """Node friction at rest, F_c0 + μ_T T_pre [N]."""
        return self.friction_c0 + self.friction_mu_tension * self.pretension

    def replace(self, **changes: Any) -> "TendonBench":
        """A copy with some fields changed (``bench.replace(k_z=1e3)``)."""
        return replace(self, **changes)

    def plant_params(self) -> dict[str, float]:
        """Parameters of the linear plant (S1 eq. 2) for :mod:`tendyn.analysis.tendon_drive`."""
        return {"m1": self.mass_motor, "c1": self.damping_motor, "k1": self.k1, "k2": self.k2,
                "mass_load": self.mass_load, "k_z": self.k_z}

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def _unknown(key: str, known: tuple[str, ...] | list[str], fname: str, field: str) -> DeviceError:
    close = difflib.get_close_matches(key, known, n=1, cutoff=0.6)
    hint = f" (did you mean {close[0]!r}?)" if close else f" (known fields: {', '.join(known)})"
    return DeviceError(f"unknown field{hint}", file=fname, field=field)


def load_tendon_bench(path: str | os.PathLike, raw: dict | None = None) -> TendonBench:
    """Load and validate a 2N tendon bench file.

    Parameters
    ----------
    path : str or os.PathLike
        The TOML file (``[device].kind = "tendon_bench_2n"``).
    raw : dict, optional
        The file's parsed TOML when the caller has read it already (:func:`tendyn.device.load_device`).

    Returns
    -------
    TendonBench

    Raises
    ------
    DeviceError
        Missing file, TOML syntax, unknown or missing field, wrong type, NaN/Inf or out-of-range value.
        The message names the file and the field (``mcgill_bench.toml: bench.k1: must be > 0 (got -1.0)``).
    """
    p = Path(path)
    fname = p.name
    if raw is None:
        raw = read_toml(p)

    for key in raw:
        if key not in TOP_KEYS:
            raise _unknown(key, TOP_KEYS, fname, key)

    # [device]
    dev = raw.get("device")
    if dev is None:
        raise DeviceError("missing required table [device]", file=fname, field="device")
    if not isinstance(dev, dict):
        raise DeviceError(f"must be a table (got {_typename(dev)})", file=fname, field="device")
    for key in dev:
        if key not in DEVICE_KEYS:
            raise _unknown(key, DEVICE_KEYS, fname, f"device.{key}")
    for key in DEVICE_KEYS:
        if key in dev and not isinstance(dev[key], str):
            raise DeviceError(f"must be a string (got {_typename(dev[key])})", file=fname, field=f"device.{key}")
    if "kind" not in dev:
        raise DeviceError(f"missing required field (must be {KIND!r})", file=fname, field="device.kind")
    if dev["kind"] != KIND:
        raise DeviceError(f"must be {KIND!r} for a tendon bench file (got {dev['kind']!r})", file=fname,
                          field="device.kind")
    name = dev.get("name", TendonBench.name)
    for key, problem in (("name", name_problem(name)), ("description", text_problem(dev.get("description", "")))):
        if problem:       # the domains of tendyn.text (issue 36), as for any device file
            raise DeviceError(problem, file=fname, field=f"device.{key}")

    # [bench]
    bench = raw.get("bench")
    if bench is None:
        raise DeviceError("missing required table [bench]", file=fname, field="bench")
    if not isinstance(bench, dict):
        raise DeviceError(f"must be a table (got {_typename(bench)})", file=fname, field="bench")
    known = list(BENCH_FIELDS)
    for key in bench:
        if key not in BENCH_FIELDS:
            raise _unknown(key, known, fname, f"bench.{key}")
    values: dict[str, float] = {}
    for key, (unit, lo, lo_open, hi, doc) in BENCH_FIELDS.items():
        field = f"bench.{key}"
        if key not in bench:
            if key in BENCH_OPTIONAL:
                continue
            raise DeviceError(f"missing required field: {doc} [{unit}]", file=fname, field=field)
        v = bench[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise DeviceError(f"must be a number [{unit}] (got {_typename(v)})", file=fname, field=field)
        v = float(v)
        if not math.isfinite(v):
            raise DeviceError(f"must be finite (got {v!r})", file=fname, field=field)
        if (lo_open and not v > lo) or (not lo_open and not v >= lo):
            raise DeviceError(f"must be {'>' if lo_open else '>='} {lo:g} [{unit}] (got {v!r})", file=fname,
                              field=field)
        if hi is not None and v > hi:
            extra = (f" (amplifier corner frequency >= {AMPLIFIER_MIN_BANDWIDTH_HZ:g} Hz)"
                     if key == "amplifier_lag" else "")
            raise DeviceError(f"must be <= {hi:.6g} [{unit}]{extra} (got {v!r})", file=fname, field=field)
        values[key] = v
    return TendonBench(name=name, description=dev.get("description", ""), source=str(p), **values)
