"""`tendyn identify-term DEVICE LOG --joint J --out NEW.toml`: a position-dependent torque (cable, spring) of one
joint fitted from a sweep log, written into a copy of the device file as a ``known`` ``[[terms]]`` entry."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

from tendyn.commands.args import existing_file, not_an_input, number, out_path, refuse_other_device
from tendyn.errors import UsageError

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def _name(text: str) -> str:
    import argparse

    if not _NAME.match(text):
        raise argparse.ArgumentTypeError(f"must be a name of letters, digits and _ not starting with a digit "
                                         f"(got {text!r})")
    return text


def register(subparsers) -> None:
    p = subparsers.add_parser("identify-term", help="fit a joint's position-dependent torque (cable, spring) from a "
                                                    "sweep log and write it as a [[terms]] entry")
    p.add_argument("device", help="device file (.toml) or bundled device name")
    p.add_argument("log", type=existing_file, metavar="LOG", help="sweep log (.parquet or .csv): the joint moved "
                   "slowly both ways (q_joint_<j> or every q_motor_<i>; the torques of the motors driving it)")
    p.add_argument("--joint", type=number(1, 1000, integer=True), required=True,
                   help="the swept joint (file joint number, an actuated joint)")
    p.add_argument("--kind", choices=("polynomial", "table"), default="polynomial",
                   help="polynomial in q (constant included) or a table linear between knots")
    p.add_argument("--order", type=number(1, 12, integer=True), default=7, help="polynomial order [1, 12]")
    p.add_argument("--knots", type=number(2, 1000, integer=True), default=20,
                   help="number of knots of a table [2, 1000], evenly over the swept range")
    p.add_argument("--velocity-fraction", type=number(0.0, 1.0, unit="-"), default=None,
                   help="leave out samples slower than this fraction of the peak |velocity| [0, 1] (default "
                        "tendyn.ident.term_fit.DEFAULT_SWEEP_VELOCITY_FRACTION)")
    p.add_argument("--name", type=_name, default=None, help="term name (default cable<joint>)")
    p.add_argument("--out", type=out_path((".toml",)), help="new device file (.toml): DEVICE with the term added")
    p.add_argument("--force", action="store_true", help="use a log whose meta names another device")
    p.add_argument("--json", action="store_true", help="print the fit as one JSON document on stdout")
    p.set_defaults(func=cmd_identify_term)


def sweep_signals(dev, log, joint: int):
    """(q [rad], q̇ [rad/s], τ [N·m]) of the swept ``joint`` (file number) in a log: q from ``q_joint_<j>`` (else
    the motor positions through G⁻¹), q̇ from ``qd_joint_<j>`` (else the motors', else dq/dt), τ = Σ_i G_ij y_i
    over the motors that reach the joint (their ``torque_motor_<i>`` must be in the log)."""
    import numpy as np

    from tendyn.ident.estimate import cached_model
    from tendyn.io import LogError

    m = cached_model(dev)
    if joint not in m.active_numbers:
        raise UsageError(f"{joint} is not an actuated joint of {dev.name} (actuated: "
                         f"{', '.join(map(str, m.active_numbers))})", "joint")
    k = m.active_numbers.index(joint)
    m.check_units(log.units)
    if f"q_joint_{joint}" in log:
        q = np.asarray(log[f"q_joint_{joint}"], float)
    else:
        try:
            qm = log.stack("q_motor_")
        except (KeyError, ValueError):
            raise LogError(f"a sweep needs q_joint_{joint} or every q_motor_1…q_motor_{m.n_motors}",
                           column=f"q_joint_{joint}") from None
        if qm.shape[1] != m.n_motors:
            raise LogError(f"the log has {qm.shape[1]} motor positions, {dev.name} has {m.n_motors}",
                           column="q_motor_")
        q = (np.linalg.solve(m.G, qm.T).T + m.joint_offsets)[:, k]
    if f"qd_joint_{joint}" in log:
        qd = np.asarray(log[f"qd_joint_{joint}"], float)
    elif all(f"qd_motor_{i + 1}" in log for i in range(m.n_motors)):
        qd = np.linalg.solve(m.G, log.stack("qd_motor_").T).T[:, k]
    else:
        qd = np.gradient(q, log.time)
    motors = [i for i in range(m.n_motors) if abs(m.G[i, k]) > 1e-12]
    missing = [f"torque_motor_{i + 1}" for i in motors if f"torque_motor_{i + 1}" not in log]
    if missing:
        raise LogError(f"the torque of joint {joint} needs the motors that drive it: {', '.join(missing)}",
                       column=missing[0])
    tau = sum(m.G[i, k] * np.asarray(log[f"torque_motor_{i + 1}"], float) for i in motors)
    return q, qd, tau


def cmd_identify_term(args) -> int:
    from tendyn.devices import load
    from tendyn.ident.lsq import IdentificationError
    from tendyn.ident.term_fit import DEFAULT_SWEEP_VELOCITY_FRACTION, TermFit
    from tendyn.io import atomic_write_text, read_log

    dev = load(args.device)
    if dev.kind != "serial":
        raise UsageError(f"{dev.name} is a {dev.kind}: a term needs a serial device", "device")
    log = read_log(args.log)
    refuse_other_device(args.log.name, log.meta["device"], dev, args.force)
    name = args.name or f"cable{args.joint}"
    if any(t.name == name for t in (getattr(dev, "terms", ()) or ())):
        raise UsageError(f"{dev.name} already has a term {name!r}: give another --name", "name")
    q, qd, tau = sweep_signals(dev, log, args.joint)
    vf = DEFAULT_SWEEP_VELOCITY_FRACTION if args.velocity_fraction is None else args.velocity_fraction
    if vf >= 1.0:
        raise UsageError(f"must be below 1 (got {vf:g})", "velocity_fraction")
    fit = TermFit(args.kind, args.order, args.knots, vf)
    try:
        fit.fit(q, qd, tau)
    except IdentificationError as exc:
        raise UsageError(f"{args.log.name}: {exc}", "log") from None
    text = fit.term_toml(name, args.joint, source=args.log.name)
    doc = {"device": dev.name, "log": str(args.log), "joint": args.joint, "name": name, **fit.to_dict()}
    if args.out:
        src = getattr(dev, "path", None)
        if src is None or not Path(src).is_file():
            raise UsageError(f"{args.device}: --out needs the device file to copy (a .toml path)", "device")
        not_an_input(args.out, [src, args.log])
        new = Path(src).read_text(encoding="utf-8").rstrip("\n") + "\n\n" + text
        _check_device_text(new, Path(args.out), Path(src))
        atomic_write_text(args.out, new)
        doc["out"] = str(args.out)
    if args.json:
        print(json.dumps(doc, indent=2))
    else:
        print(text, end="")
        print(f"# fitted on {fit.n_samples_} samples; coefficient %sigma: "
              + ", ".join(f"{s:.3g}" for s in fit.rel_stderr_pct_))
    if not args.out:
        print("tendyn identify-term: no --out: append the [[terms]] entry above to the device file", file=sys.stderr)
    return 0


def _check_device_text(text: str, out: Path, src: Path) -> None:
    """Load the new device text (beside the source, for its relative URDF) before writing it: a file that does
    not load is never written."""
    import tempfile

    from tendyn.device import load_device

    try:
        f = tempfile.NamedTemporaryFile("w", suffix=".toml", dir=src.parent, delete=False, encoding="utf-8")
    except OSError:                     # a read-only folder (an installed bundled device): beside the output
        f = tempfile.NamedTemporaryFile("w", suffix=".toml", dir=out.parent, delete=False, encoding="utf-8")
    with f:
        f.write(text)
        tmp = Path(f.name)
    try:
        load_device(tmp)
    finally:
        tmp.unlink(missing_ok=True)
