"""The one base type of every device kind: what any caller (CLI, pipelines, reports) may ask of a device
without knowing its class.

Only the standard library is used.
"""

from __future__ import annotations

from pathlib import Path
from typing import ClassVar

__all__ = ["EXPERIMENTS", "Device"]

EXPERIMENTS = ("constant-velocity", "exciting", "blocked-link", "stepped-sine", "swept-sine", "low-speed-loop", "prbs")
"""Every experiment name a device may support (the CLI's names, ``tendyn simulate DEVICE EXPERIMENT``)."""


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
