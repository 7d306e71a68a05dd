"""The identified model as an object: a PARAMS.json that loads back, predicts the torques of a log and scores it.

``tendyn identify --out PARAMS.json`` (or :meth:`tendyn.ident.IDIM.identified_model`) writes one versioned
document (``"format": "tendyn.params/1"``): the device and the SHA-256 of its file, the base parameters
(name, value, σ, %σ, unit, expression), the method and the treatment. :meth:`IdentifiedModel.load` reads it
back (older PARAMS.json without the format key too), on the device it names or on one given;
:meth:`IdentifiedModel.predict` gives the torques of any log of that device, at the log's own time stamps,
in joint and motor coordinates; :meth:`IdentifiedModel.score` the per-joint relative error against the
log's measured torques. The model is the IDIM's, S2 eq. 4: τ = W(q, q̇, q̈) X with X the base parameters
(each on the column of the first standard parameter of its expression, :meth:`IdentModel.parameter_vector`).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from tendyn.results import Result, format_table, new_figure

__all__ = ["FORMAT", "IdentifiedModel", "TorquePrediction"]

FORMAT = "tendyn.params/1"
"""The ``format`` key of a PARAMS.json this module writes."""

_CHUNK = 20_000
"""Samples per regressor call in :meth:`IdentifiedModel.predict` (bounds the memory of W on long logs)."""


def device_digest(device) -> str | None:
    """SHA-256 of a device's file and of its URDF when it has one (None for a device without a file)."""
    path = getattr(device, "path", None)
    if path is None or not Path(path).is_file():
        return None
    h = hashlib.sha256(Path(path).read_bytes())
    urdf = getattr(getattr(device, "kinematics", None), "urdf", None)
    if urdf is not None and Path(urdf).is_file():
        h.update(Path(urdf).read_bytes())
    return h.hexdigest()


def provenance(device) -> dict:
    """The keys of PARAMS.json that say what it is and which device file it was identified on."""
    path = getattr(device, "path", None)
    return {"format": FORMAT, "device_file": None if path is None else str(path),
            "device_sha256": device_digest(device)}


class TorquePrediction(Result):
    """Predicted and measured torques of one log at its own sample times.

    Two spaces: **joint** (``joint``, ``measured``, :attr:`relative_error`: τ = Gᵀ y, the space
    ``tendyn identify`` fits and reports its residuals in) and **motor** (``motor``, ``measured_motor``,
    :attr:`relative_error_motor`: y = G⁻ᵀ τ, what the motors' drives see). ``time`` (n,) [s]; ``joint``
    (n, n_a) predicted joint torques [N·m, N at a prismatic joint]; ``motor`` (n, n_m) the motor torques
    y = G⁻ᵀ τ̂ that produce them; ``measured`` (n, n_a) the log's joint torques τ = Gᵀ y, low-passed by the
    zero-phase Butterworth of the positions (what the prediction can follow); ``measured_motor`` (n, n_m) the
    same in motor space; ``edge`` samples at each end are left out of the errors (the filters' transients and
    the one-sided differences, which the identification leaves out too: its parallel filter keeps full windows
    only); ``joint_numbers`` (file joint numbers); ``units`` of each joint's torque.
    """

    _figsize = (8.0, 2.6)

    def __init__(self, device, time, joint, motor, measured, joint_numbers, units, measured_motor=None, edge=0,
                 coupled=False):
        self.device, self.time = device, np.asarray(time)
        self.joint, self.motor, self.measured = np.asarray(joint), np.asarray(motor), np.asarray(measured)
        self.measured_motor = None if measured_motor is None else np.asarray(measured_motor)
        self.joint_numbers, self.units = list(joint_numbers), list(units)
        self.edge = int(edge) if self.time.size > 2 * int(edge) else 0
        self.coupled = bool(coupled)
        self._panels = len(self.joint_numbers)

    @staticmethod
    def _rel(measured, predicted, edge) -> np.ndarray:
        sl = slice(edge, measured.shape[0] - edge)
        return np.linalg.norm(measured[sl] - predicted[sl], axis=0) / np.maximum(
            np.linalg.norm(measured[sl], axis=0), 1e-300)

    @property
    def relative_error(self) -> np.ndarray:
        """Per joint ‖τ_measured − τ̂‖ / ‖τ_measured‖ [-] in joint space, over the log's samples but ``edge``
        at each end."""
        return self._rel(self.measured, self.joint, self.edge)

    @property
    def relative_error_motor(self) -> np.ndarray | None:
        """Per motor ‖y_measured − ŷ‖ / ‖y_measured‖ [-] in motor space (y = G⁻ᵀ τ), same samples."""
        return None if self.measured_motor is None else self._rel(self.measured_motor, self.motor, self.edge)

    def to_dict(self) -> dict:
        em = self.relative_error_motor
        return {"device": self.device, "joint_numbers": self.joint_numbers, "units": self.units,
                "relative_error": [float(v) for v in self.relative_error], "space": "joint",
                "relative_error_motor": None if em is None else [float(v) for v in em],
                "n_samples": int(self.time.size), "edge_samples": self.edge}

    def table(self) -> str:
        em = self.relative_error_motor
        both = self.coupled and em is not None and len(em) == len(self.joint_numbers)
        rows = [(j, u, f"{100 * e:.3g}") + ((f"{100 * em[k]:.3g}",) if both else ())
                for k, (j, u, e) in enumerate(zip(self.joint_numbers, self.units, self.relative_error))]
        head = ("Joint", "Unit", "Relative error % (joint space)") + (("Motor k: relative error % (motor space)",)
                                                                       if both else ())
        return format_table(head, rows, title=f"{self.device}: predicted vs measured torques, {self.time.size} "
                                              f"samples ({self.edge} at each end left out)")

    reading = ("One panel per joint: the log's torque (colour, low-passed like the identification) and the torque "
               'the identified model predicts (black dashes) over the same time.')

    def plot(self, ax=None):
        if ax is None:
            n = self._panels
            _, axes = new_figure(n, 1, figsize=(self._figsize[0], self._figsize[1] * n), sharex=True)
            ax = list(np.ravel(axes))
        self._draw(ax)
        return (ax[0] if isinstance(ax, (list, tuple)) else ax).figure

    def _draw(self, ax):
        axes = ax if isinstance(ax, (list, tuple)) else [ax]
        for k, a in enumerate(axes[:len(self.joint_numbers)]):
            a.plot(self.time, self.measured[:, k], lw=0.8, color=f"C{k}", label="measured (filtered)")
            a.plot(self.time, self.joint[:, k], lw=0.8, ls="--", color="k", label="predicted")
            a.set_ylabel(f"joint {self.joint_numbers[k]} [{self.units[k]}]")
            a.legend(loc="best", fontsize=7)
        axes[-1].set_xlabel("time [s]")


class IdentifiedModel:
    """Identified base parameters of a device, loadable, with ``predict(log)`` and ``score(log)``.

    Parameters
    ----------
    device : Device, CompiledDevice or path
        The device the parameters belong to.
    params : list of dict
        ``{name, value, stderr, rel_stderr_pct, unit, expression}`` per base parameter (the ``params`` of
        PARAMS.json).
    method : str
    treatment : dict or None
        The treatment of the identification (:meth:`Treatment.to_dict`): its cut-off and order filter the
        positions of a predicted log (capped below the log's Nyquist frequency), its ``velocities`` choice
        applies.
    force : bool
        Predict logs of another device (``meta.device``) anyway (``--force``); default refused, as by identify.
    omitted : sequence of str
        Base parameters left out on purpose (``identify --essential`` / ``--parameters``: taken as 0), kept so
        that :meth:`to_dict` writes a document the readers accept again.
    """

    def __init__(self, device, params, method="ols", treatment=None, force: bool = False, omitted=()):
        from tendyn.device.compiled import as_device

        self.device = as_device(device) if not isinstance(device, (str, Path)) else _load_device(device)
        self.params = [dict(p) for p in params]
        self.method = method
        self.treatment = dict(treatment or {})
        self.force = bool(force)
        self.omitted = [str(n) for n in omitted]

    # -- file -------------------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        return {**provenance(self.device), "device": self.device.name, "method": self.method,
                "params": self.params, "omitted": list(self.omitted), "treatment": self.treatment}

    def save(self, path) -> Path:
        """Write the PARAMS.json document atomically (:data:`FORMAT`)."""
        from tendyn.io import atomic_write_text, to_jsonable

        atomic_write_text(path, json.dumps(to_jsonable(self.to_dict()), indent=2) + "\n")
        return Path(path)

    @classmethod
    def load(cls, path, device=None, force: bool = False) -> "IdentifiedModel":
        """Read a PARAMS.json (``tendyn identify --out``). ``device``: the device (object, file or bundled
        name); default the file it names (``device_file``, else the bundled device of its name). Raises
        :class:`tendyn.io.params.ParamsError` (a ValueError naming the file and the field) for a bad
        document, one of another device or identified on another version of the device file (its SHA-256
        differs) — both accepted with ``force`` — and, always, one with a parameter the device does not have
        or missing one of its base parameters (the same checks as ``identify --stream`` and ``maps``)."""
        from tendyn.io.files import read_json
        from tendyn.io.params import ParamsError

        try:
            doc = read_json(path)
        except OSError as exc:
            raise ParamsError(f"cannot read the file: {exc.strerror or exc}", None, str(path)) from None
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise ParamsError(f"not a JSON document: {exc}", None, str(path)) from None
        return cls.from_document(doc, device=device, force=force, source=str(path))

    @classmethod
    def from_document(cls, doc, device=None, force: bool = False, source: str | None = None) -> "IdentifiedModel":
        """The model of a PARAMS.json document already read (:meth:`load`, a calibrated device's ``params``), with
        the checks of :meth:`load`; ``source`` names the document in the errors."""
        from tendyn.io.params import ParamsError, read_params

        def named(exc):
            return exc if exc.file or not source else ParamsError(exc.problem, exc.field, source)

        try:
            params = read_params(doc)          # the one validated reader of PARAMS.json
        except ParamsError as exc:
            raise named(exc) from None
        if not hasattr(doc, "get"):
            raise ParamsError("must be the document of `tendyn identify --out`, a JSON object", None, source)
        fmt = doc.get("format", FORMAT)
        if fmt != FORMAT:
            raise ParamsError(f"{fmt!r}: this tendyn reads {FORMAT!r}", "format", source)
        if device is None:
            device = doc.get("device_file") if doc.get("device_file") and Path(doc["device_file"]).is_file() \
                else doc.get("device")
        model = cls(device, params, doc.get("method", "ols"), doc.get("treatment"), force=force,
                    omitted=doc.get("omitted") or ())
        m = model._model()
        try:
            read_params(doc, model.device, force, standard_names=m.standard_names, base_names=m.base.names)
        except ParamsError as exc:
            raise named(exc) from None
        want, have = doc.get("device_sha256"), device_digest(model.device)
        if want and have and want != have and not force:
            raise ParamsError(f"identified on another version of {model.device.name}'s file (SHA-256 {want[:12]}… "
                              f"in PARAMS.json, {have[:12]}… now)", "device_sha256", source)
        return model

    # -- use --------------------------------------------------------------------------------------------
    def _model(self):
        from .model import cached_model

        return cached_model(self.device)

    def predict(self, log, filter_prediction: bool = True) -> TorquePrediction:
        """Joint and motor torques of a log (a Log or a path) predicted from its positions, one per sample at
        the log's time stamps. The positions are treated as in the identification (stale rows dropped and
        re-timed, zero-phase Butterworth, central differences or logged velocities), without decimation; the
        predicted torques go through the same zero-phase Butterworth as the measured ones (parallel filtering;
        ``filter_prediction=False``: not, as a peer's metric that compares the raw model output does)."""
        from tendyn.io import read_log

        from .treatment import butter_zero_phase, central_differences, default_treatment, drop_stale

        if not hasattr(log, "meta"):
            log = read_log(log)
        named = log.meta.get("device")
        if not self.force and named is not None and not self.device.is_named(named):
            from tendyn.io.logs import LogError

            raise LogError(f"is a log of the device {named!r}, not {self.device.name!r} (force=True, --force, to "
                           "predict it anyway)", file=getattr(log, "path", None), column="meta.device")
        m = self._model()
        time, q, tau = m.joint_signals(log)
        qd_log = None if self.treatment.get("velocities") == "differentiate" else m.joint_velocities(log)
        rate = float(log.meta["rate_hz"])
        t, q, tau_t, qd_log, _, retimed = drop_stale(time, rate, q, tau, qd_log)
        cut = self.treatment.get("cutoff_hz")
        tr = default_treatment(rate, getattr(m.device, "bandwidth_hz", None),
                               cut if cut is not None and cut < 0.45 * rate else None,
                               order=int(self.treatment.get("order", 4)))
        qf = butter_zero_phase(q, tr.cutoff_hz, rate, tr.order)
        qd = central_differences(qf, 1.0 / rate) if qd_log is None else butter_zero_phase(qd_log, tr.cutoff_hz,
                                                                                          rate, tr.order)
        qdd = central_differences(qd, 1.0 / rate)
        x = m.parameter_vector(self.params)
        na = m.n_active
        out = []
        for s in range(0, t.size, _CHUNK):
            sl = slice(s, s + _CHUNK)
            n = qf[sl].shape[0]
            out.append((m.regressor(qf[sl], qd[sl], qdd[sl]) @ x).reshape(na, n).T)
        joint = np.vstack(out)
        known = m.known_torque(qf)          # [[terms]] of kind "known": part of the model, not identified
        if known is not None:
            joint = joint + known
        measured = butter_zero_phase(tau_t, tr.cutoff_hz, rate, tr.order)
        # the model's torque through the same low-pass as the measured one (the identification's parallel filter
        # does this to both Y and W): a Coulomb step is then compared with the measured, smoothed step
        if filter_prediction:
            joint = butter_zero_phase(joint, tr.cutoff_hz, rate, tr.order)
        if retimed:     # back onto the log's own time stamps
            joint, measured = ([np.column_stack([np.interp(time, t, x[:, j]) for j in range(na)])
                                for x in (joint, measured)])
        motor = m.motor_torques(joint)                      # y = G⁻ᵀ τ (coupling.py: motor_from_joint_torque)
        # the log's own motor torques (τ = Gᵀ y undone exactly), filtered like the joint ones: not through
        # motor_torques, so a wrong map there shows as a motor-space error
        measured_motor = np.linalg.solve(m.G.T, measured.T).T
        units = ["N" if j in m.prismatic_numbers else "N·m" for j in m.active_numbers]
        from .model import diagonal_coupling

        K = int(self.treatment.get("decimate") or 1)
        edge = max(5 * K if K > 1 else 0, int(np.ceil(2.0 * rate / tr.cutoff_hz))) + 1
        return TorquePrediction(m.device.name, time, joint, motor, measured, m.active_numbers, units,
                                measured_motor=measured_motor, edge=edge, coupled=not diagonal_coupling(m.G))

    def score(self, log) -> np.ndarray:
        """Per joint relative error ‖τ_measured − τ̂‖ / ‖τ_measured‖ [-] of a log (see :meth:`predict`)."""
        return self.predict(log).relative_error


def _load_device(arg):
    from tendyn.devices import load

    return load(arg)