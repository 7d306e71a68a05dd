"""The one base type of every device kind: what any caller (CLI, pipelines, reports) may ask of a device
without knowing its class.

Only the standard library is used.
"""

from __future__ import annotations

from pathlib import Path
from typing import ClassVar

__all__ = ["EXPERIMENTS", "Device", "DeviceError"]

EXPERIMENTS = ("constant-velocity", "exciting", "blocked-link", "stepped-sine", "swept-sine", "low-speed-loop", "prbs")
"""Every experiment name a device may support (the CLI's names, ``tendyn simulate DEVICE EXPERIMENT``)."""


class DeviceError(ValueError):
    """A device file (or a request about bundled devices) is invalid.

    The message names the file, the field path and what is wrong, e.g.
    ``lexos.toml: transmissions[2].driven_radius: must be > 0 (got 0.0): ...``.

    Attributes
    ----------
    file : str or None
        The file name the error is about (None when no file is involved).
    field : str or None
        The dotted field path, with 1-based indices of array entries (``transmissions[2].friction[1].tau0``).
    problem : str
        What is wrong, without the file and field prefix.
    """

    def __init__(self, problem: str, *, file: str | None = None, field: str | None = None):
        self.file = file
        self.field = field
        self.problem = problem
        parts = [p for p in (file, field) if p]
        super().__init__(": ".join(parts + [problem]))


class Device:
    """Base of every device description (:class:`~tendyn.device.schema.SerialDevice`,
    :class:`~tendyn.device.tendon_bench.TendonBench`).

    Attributes
    ----------
    kind : str
        ``"serial"`` (a serial or tree mechanism with cable transmissions or capstan drives) or
        ``"tendon_bench_2n"`` (the S1 2N tendon bench); the ``[device].kind`` of the file.
    experiments : tuple of str
        The experiment names (from :data:`EXPERIMENTS`) a twin of this device supports.
    name : str
        Device name (``[device].name``).
    description : str
        Free text.
    path : pathlib.Path or None
        The file the description was read from (None when built in code).
    source : str or None
        ``str(path)``, or None.

    A subclass defines ``kind`` and ``experiments`` as class attributes and ``name``, ``description`` and
    ``path`` or ``source`` as fields.
    """

    kind: ClassVar[str] = ""
    experiments: ClassVar[tuple[str, ...]] = ()

    def __getstate__(self):  # copies and pickles do not carry the compiled models (compile_device)
        state = dict(self.__dict__)
        state.pop("_compiled", None)
        return state

    def is_named(self, named) -> bool:
        """Whether ``named`` (a log's ``meta.device``, a PARAMS.json's or FRICTION.json's ``device``) names this
        device: its name, its file path or the file's stem (``lexos`` for the bundled ``lexos.toml``)."""
        path = getattr(self, "path", None)
        known = {self.name} | ({str(path), Path(path).stem} if path else set())
        return isinstance(named, str) and named in known

    def supports(self, experiment: str) -> bool:
        """Whether ``experiment`` (a CLI experiment name such as ``"stepped-sine"``) runs on this device."""
        return experiment in self.experiments

    def check_experiment(self, experiment: str) -> None:
        """Raise ValueError naming the device and its experiments unless ``experiment`` is supported."""
        if experiment not in self.experiments:
            raise ValueError(f"{self.name} ({self.kind}) has no experiment {experiment!r}; "
                             f"its experiments: {', '.join(self.experiments)}")
