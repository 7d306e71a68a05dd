"""``tendyn export``: the model files a C/C++ controller loads, from a device and its identified friction.

::

    tendyn export compensator DEVICE --friction FRICTION.json [--shares SHARES.json] [--k 0.7] --out X.comp
    tendyn export transmission DEVICE [--friction FRICTION.json] [--shares SHARES.json] --out X.model
    tendyn export mjcf DEVICE [--lossless] [--timestep S] --out X.xml
    tendyn export ros2-control DEVICE [--four-bar] --out X.urdf

The compensator file is read by ``tendyn_compensator_load`` (C), ``load_compensator_model`` (C++) and
``tendyn.control.Compensator.load``; the transmission file by ``tendyn_transmission_load``. With ``--friction``
the identified losses replace every loss term of the device file (one loss model at a time:
:mod:`tendyn.ident.loss_model`), and the compensator file records each term's source (``section losses``).

``mjcf`` and ``ros2-control`` take the device to a simulator and to a ROS 2 controller: a MuJoCo model
(:mod:`tendyn.interop.mjcf`) and a URDF ``<ros2_control>`` block with transmissions (:mod:`tendyn.interop.ros2_control`),
for any device kind (``[[transmissions]]``, ``[[drives]]``, ``[[actuators]]``), coupling from
:func:`tendyn.coupling.coupling`.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from tendyn.commands import args as conv
from tendyn.errors import UsageError

KINDS = ("compensator", "transmission", "mjcf", "ros2-control")
SUFFIXES = {"compensator": (".comp", ".txt"), "transmission": (".model", ".txt"), "mjcf": (".xml",),
            "ros2-control": (".urdf", ".xml")}
CHECK_SPEEDS = (1.0, 5.0)
"""Motor speeds [rad/s] at which the summary shows the friction the exported model compensates."""


def add_arguments(subparsers) -> argparse.ArgumentParser:
    from tendyn.control.compensator import (DEFAULT_VELOCITY_BAND, DEFAULT_VELOCITY_CUTOFF_HZ,
                                            IDENTIFIED_UNDERESTIMATION)

    p = subparsers.add_parser("export", help="write the model file a controller or simulator loads (compensator, "
                                             "transmission, MuJoCo MJCF, ros2_control URDF)")
    p.add_argument("kind", choices=KINDS, help="compensator (.comp, tendyn_compensator_load), transmission "
                                               "(.model, tendyn_transmission_load), mjcf (.xml, MuJoCo) or "
                                               "ros2-control (.urdf, ros2_control transmissions)")
    p.add_argument("device", help="device file (.toml) or bundled twin name")
    p.add_argument("--friction", type=conv.existing_file, default=None, metavar="FRICTION.json",
                   help="identified friction (identify-friction's FRICTION.json or decompose --json); it replaces "
                        "every loss term of the device file (required for a compensator)")
    p.add_argument("--shares", type=conv.existing_file, default=None, metavar="SHARES.json",
                   help="loss shares p, p' per branch (tendyn.shares/1) for the decomposition (default: from the "
                        "construction)")
    p.add_argument("--k", type=conv.number(0.0, 1.5), default=IDENTIFIED_UNDERESTIMATION,
                   help=f"under-estimation factor k in [0, 1.5] of the friction part (default "
                        f"{IDENTIFIED_UNDERESTIMATION:g}; > 1 over-compensates and can make the device active)")
    p.add_argument("--velocity-band", type=conv.number(0.0, 1e3, unit="rad/s"), default=DEFAULT_VELOCITY_BAND,
                   help=f"motor speed below which the friction feedforward fades to 0 [rad/s] (default "
                        f"{DEFAULT_VELOCITY_BAND:g})")
    p.add_argument("--velocity-cutoff", type=conv.number(0.0, 1e5, unit="Hz"), default=DEFAULT_VELOCITY_CUTOFF_HZ,
                   help=f"velocity filter cut-off [Hz] (default {DEFAULT_VELOCITY_CUTOFF_HZ:g})")
    p.add_argument("--rate", type=conv.number(100.0, 1e5, unit="Hz"), default=1000.0,
                   help="control rate of the loop that runs the compensator [Hz] (default 1000)")
    p.add_argument("--lossless", action="store_true", help="mjcf: leave every friction and damping term out")
    p.add_argument("--timestep", type=conv.number(1e-6, 0.1, unit="s"), default=1e-3,
                   help="mjcf: MuJoCo time step [s] (default 0.001)")
    p.add_argument("--four-bar", action="store_true",
                   help="ros2-control: export four-bar-shaped 2×2 blocks as FourBarLinkageTransmission (its effort "
                        "map is not the transpose of its position map)")
    p.add_argument("--out", type=conv.out_path((".comp", ".model", ".txt", ".xml", ".urdf")), required=True,
                   help="the file to write (atomically): .comp, .model, .txt, .xml (mjcf) or .urdf (ros2-control)")
    p.add_argument("--json", action="store_true", help="print a summary as JSON on stdout")
    p.set_defaults(func=run_export)
    conv.applies(p, "export")
    return p


def run_export(args) -> int:
    from tendyn.commands.s0 import _print_json, cable_device

    conv.check_applies(args)
    conv.check_needs("export", args)
    if args.out.suffix.lower() not in SUFFIXES[args.kind]:
        raise UsageError(f"must end in {' or '.join(SUFFIXES[args.kind])} for {args.kind} (got {str(args.out)!r})",
                         "out")
    if args.kind in ("mjcf", "ros2-control"):
        return _export_other(args)
    from tendyn.commands.shared import calibrated
    from tendyn.control import Compensator
    from tendyn.ident.calibrated import CalibrationError

    dev = cable_device(args.device, "to export", drives=True)
    if args.kind == "compensator":        # before any file is read: the name must fit the .comp's device line
        from tendyn.control.compensator import device_line_problem

        problem = device_line_problem(dev.name)
        if problem:
            raise UsageError(f"its name {dev.name!r} cannot be written in a .comp file: {problem}", "device")
    if args.kind == "compensator" and args.friction is None:
        raise UsageError("a compensator is exported from identified friction (tendyn identify-friction); "
                         "without it, Compensator.from_device(device).export(path) uses the device file's "
                         "nominal losses", "friction")
    # the device file with the identified friction laid over it: one loss model, read once
    cal = calibrated(dev, args.friction, shares=args.shares)
    try:
        losses = cal.loss_model()        # a differential's motor-side friction: refused, not mis-decomposed
    except CalibrationError as exc:
        raise UsageError(str(exc)) from None
    if args.kind == "compensator":
        comp = Compensator.from_device(cal, underestimation=args.k,
                                       velocity_band=args.velocity_band, velocity_cutoff_hz=args.velocity_cutoff,
                                       rate_hz=args.rate)
        comp.export(args.out)
        Compensator.load(args.out, expected_device=dev.name)     # read back: what a C controller will load
    transmission = cal.transmission()
    if args.kind != "compensator":
        transmission.export(args.out)
    rows = _summary_rows(transmission)
    summary = {"out": str(args.out), "kind": args.kind, "device": dev.name,
               "friction": None if args.friction is None else str(args.friction),
               "sources": losses.sources if losses is not None else "device", "underestimation": args.k,
               "friction_at_motor": rows, "units": {"friction_at_motor": "N·m", "speed": "rad/s"}}
    if args.kind == "compensator" and args.k > 1.0:
        print(f"tendyn: warning: --k {args.k:g} > 1 over-compensates the identified friction: the device can "
              "inject energy into the hand (limit cycles on a wall)", file=sys.stderr)
    if args.json:
        _print_json(summary)
    else:
        print(f"{args.out}: {args.kind} model of {dev.name} ({len(rows)} "
              f"{'transmissions' if dev.transmissions else 'capstan drives, one-branch transmissions'})"
              + (f", losses identified from {args.friction} (sources: "
                 + ", ".join(f"{k} {v}" for k, v in losses.sources.items()) + ")" if losses else ", device losses"))
        for r in rows:
            print(f"  transmission {r['transmission']}: friction at the motor, zero load "
                  + ", ".join(f"{r['friction'][k]:.4g} N·m at {v:g} rad/s" for k, v in enumerate(CHECK_SPEEDS)))
    return 0


def _summary_rows(transmission) -> list[dict]:
    """Friction [N·m] the exported transmission puts at each motor moving alone at CHECK_SPEEDS, zero load."""
    n = transmission.n
    rows = []
    for j in range(n):
        f = []
        for v in CHECK_SPEEDS:
            qd = transmission.motor_alone_joint_speeds(j, v)
            f.append(float(transmission.feedforward(np.zeros(n), qd).torque_motor[j]))
        rows.append({"transmission": j + 1, "speeds": list(CHECK_SPEEDS), "friction": f})
    return rows


def _export_other(args) -> int:
    """``export mjcf`` and ``export ros2-control``: any serial device, the device file's own losses."""
    from tendyn.commands.s0 import _load_device, _print_json
    from tendyn.io import atomic_write_text

    if args.friction is not None or args.shares is not None:
        raise UsageError(f"{args.kind} is exported from the device file's losses; --friction/--shares apply to "
                         "compensator and transmission", "friction")
    dev = _load_device(args.device)
    if getattr(dev, "kind", None) != "serial":
        raise UsageError(f"{dev.name} is a tendon bench (one 2N channel): it has no joint chain to export", "device")
    if args.kind == "mjcf":
        from tendyn.interop.mjcf import not_expressible, to_mjcf

        text = to_mjcf(dev, timestep=args.timestep, losses=not args.lossless)
        left_out = ["every loss term (--lossless)"] if args.lossless else not_expressible(dev)
        summary = {"out": str(args.out), "kind": "mjcf", "device": dev.name, "timestep_s": args.timestep,
                   "tendons": text.count("<fixed "), "actuators": text.count("<motor "), "not_expressed": left_out}
        lines = [f"{args.out}: MuJoCo model of {dev.name}: {summary['actuators']} motors on fixed tendons, "
                 f"{summary['tendons']} fixed tendons in all"]
        if left_out:
            lines.append("  not expressible in MuJoCo, left out (named in the file's comment):")
            lines += [f"    - {m}" for m in left_out]
    else:
        from tendyn.interop.ros2_control import CouplingNotExpressible, plan, to_ros2_control

        try:
            rows = plan(dev, four_bar=args.four_bar)
        except CouplingNotExpressible as exc:
            raise UsageError(f"{dev.name} cannot be written as ros2_control transmissions: {exc}") from None
        text = to_ros2_control(dev, four_bar=args.four_bar)
        summary = {"out": str(args.out), "kind": "ros2-control", "device": dev.name,
                   "transmissions": [{"type": r["type"].split("/")[-1], "motors": r["motors"], "joints": r["joints"],
                                      "actuator_reduction": r["actuator_reduction"],
                                      "joint_reduction": r["joint_reduction"]} for r in rows]}
        if any(r["type"].endswith("FourBarLinkageTransmission") for r in rows):
            print("tendyn: warning: ros2_control's four-bar effort map is not the transpose of its position map: "
                  "effort commands through it are not power-consistent with the device's coupling", file=sys.stderr)
        lines = [f"{args.out}: {len(rows)} ros2_control transmissions of {dev.name}"]
        lines += [f"  {t['type']}: {', '.join(t['motors'])} -> {', '.join(t['joints'])}"
                  for t in summary["transmissions"]]
    atomic_write_text(args.out, text)
    if args.json:
        _print_json(summary)
    else:
        print("\n".join(lines))
    return 0


def register(subparsers) -> None:
    add_arguments(subparsers)

