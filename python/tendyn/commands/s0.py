"""Command-line logic of the S0 friction workflow (issue 8, items 1–4): ``plan``, ``identify-friction``,
``decompose``. :func:`register` (found by :func:`tendyn.cli.build_parser`) adds them with
:func:`add_plan_arguments`, :func:`add_identify_friction_arguments`, :func:`add_decompose_arguments`; each
sets ``func`` to the ``run_*`` function, which returns the exit code (0) and raises :class:`tendyn.errors.UsageError` for bad
input (exit 2). No physics here: it calls :mod:`tendyn.sim.experiments` and :mod:`tendyn.ident` (the campaign's
grouping, fits and loss decomposition: :mod:`tendyn.ident.friction_campaign`).

::

    tendyn plan constant-velocity lexos --transmission 2 --strategy S2 --speeds 2,4,6,8,10 --out ref.csv
    tendyn identify-friction lexos runs/t*.parquet --out friction.json [--gravity pairs|model|both] [--json]
    tendyn decompose lexos friction.json [--shares shares.json] [--json]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from tendyn.commands import args as conv
from tendyn.commands import plan_bench, plan_exciting
from tendyn.errors import UsageError

PLAN_EXPERIMENTS = ("constant-velocity",)
LOG_SUFFIXES = (".csv", ".parquet")


def _load_device(text: str):
    """A device file path or a bundled twin name: :func:`tendyn.devices.load`."""
    from tendyn.devices import load

    return load(text)


def cable_device(text: str, what: str, drives: bool = False):
    """:func:`_load_device`, refusing a device without cable transmissions (a tendon bench, geared actuators;
    capstan drives too unless ``drives``) with one line: ``what`` says what needs them."""
    dev = _load_device(text)
    if getattr(dev, "kind", None) != "serial" or not (dev.n_transmissions or (drives and dev.drives)):
        raise UsageError(f"{dev.name} has no cable transmissions{' or capstan drives' if drives else ''} {what}",
                         "device")
    return dev


def _separable(dev, what: str) -> None:
    """One line (exit 2) when S0's identification cannot separate the losses of this routing
    (:func:`tendyn.device.routing_checks.require_separable`)."""
    from tendyn.device.routing_checks import NotSeparable, require_separable

    try:
        require_separable(dev, what)
    except NotSeparable as exc:
        raise UsageError(str(exc), "device") from None


def _print_json(doc) -> None:
    from tendyn.commands.shared import print_json

    print_json(doc, allow_nan=False)


# ---- plan -------------------------------------------------------------------------------------------

def add_plan_arguments(subparsers) -> argparse.ArgumentParser:
    """``tendyn plan constant-velocity DEVICE --transmission I --strategy S1|S2 [...] --out REF.csv``."""
    from tendyn import protocols as pr

    p = subparsers.add_parser("plan", help="write the references of a twin experiment for a real controller")
    p.add_argument("experiment", choices=PLAN_EXPERIMENTS + plan_bench.KINDS + plan_exciting.KINDS,
                   help="the experiment to plan")
    p.add_argument("device", nargs="?", default=None,
                   help="device file (.toml) or bundled twin name (lexos, …); optional for the bench plans")
    p.add_argument("--transmission", type=conv.number(1, integer=True), default=None,
                   help="1-based transmission to move (constant-velocity)")
    p.add_argument("--strategy", choices=("S1", "S2"), default="S2",
                   help="S1 holds the other motors (motor-space references), S2 the other joints (joint-space); "
                        "default S2")
    p.add_argument("--speeds", type=conv.numbers(0.0, 1000.0, lo_open=True, unit="rad/s"), default=None,
                   help=f"motor speeds [rad/s], comma-separated; one forward and one backward pass each "
                        f"(identify-friction needs >= {pr.MIN_SPEEDS}; default "
                        f"{','.join(f'{v:g}' for v in pr.DEFAULT_SPEEDS)})")
    p.add_argument("--travel", type=conv.number(0.0, 1e4, lo_open=True, unit="rad"), default=None,
                   help=f"motor travel per pass [rad] (default: the longest stroke inside the joint limits, at "
                        f"most {pr.DEFAULT_TRAVEL:g})")
    p.add_argument("--accel", type=conv.number(1e-3, 1e6, unit="rad/s²"), default=None,
                   help=f"motor acceleration of the ramps [rad/s^2] (default {pr.DEFAULT_ACCEL:g})")
    p.add_argument("--loads", type=conv.number(1, 10, integer=True), default=pr.DEFAULT_LOADS,
                   help=f"poses (gravity loads) of the test, chosen from the limits and gravity model (default "
                        f"{pr.DEFAULT_LOADS}: the load-dependent friction needs two)")
    p.add_argument("--q0", type=conv.numbers(-1e3, 1e3, unit="rad"), default=None,
                   help="start joint positions of the first pose [rad], comma-separated (default: mid-range)")
    p.add_argument("--rate", type=conv.number(0.0, 1e6, lo_open=True, unit="Hz"), default=1000.0,
                   help="sample rate of the references [Hz] (the controller's rate; default 1000)")
    p.add_argument("--out", type=conv.out_path(LOG_SUFFIXES), required=True, help="REF.csv or REF.parquet")
    p.add_argument("--json", action="store_true", help="print a summary as JSON on stdout")
    plan_bench.add_arguments(p)
    plan_exciting.add_arguments(p)
    p.set_defaults(func=run_plan)
    conv.applies(p, "plan")
    return p


def plan_constant_velocity(device, test, rate_hz: float):
    """The reference log of a planned constant-velocity test (:func:`tendyn.protocols.plan_test`): time,
    position and speed references of every motor (S1) or joint (S2); ``options`` says which are held and
    where. The same references as the twin's :func:`tendyn.sim.experiments.constant_velocity` with that test
    (at ``rate_hz``)."""
    from tendyn.io import make_log
    from tendyn.protocols import duration_s, motor_from_joint, references
    from tendyn.sim.catalogue import require_memory

    Gm = motor_from_joint(device)
    n = Gm.shape[0]
    samples = duration_s(Gm, test) * rate_hz      # checked before the references are built (plan --accel 1e-6)
    require_memory(8.0 * samples * (2 * n + 1) * 4, "fewer speeds or loads, a shorter --travel, a larger --accel "
                   "or a lower --rate", f"a plan of {samples:.3g} samples")
    ref_q, ref_v, space = references(Gm, test, 1.0 / rate_hz)
    cols = {"time": np.arange(ref_q.shape[0]) / rate_hz}
    prefix, vprefix = ("q_motor_ref_", "qd_motor_ref_") if space == "motor" else ("q_ref_", "qd_ref_")
    for i in range(n):
        cols[f"{prefix}{i + 1}"] = ref_q[:, i]
        cols[f"{vprefix}{i + 1}"] = ref_v[:, i]
    t = test.transmission
    held = [i + 1 for i in range(n) if i != t - 1]
    options = {**test.options(), "space": space, "held_motors" if space == "motor" else "held_joints": held,
               "note": (f"hold the listed motors; drive motor {t} along q_motor_ref_{t}" if space == "motor" else
                        f"hold the listed joints; drive joint {t} along q_ref_{t}") +
               (f"; {len(test.poses)} poses (loads), moved between along the references" if len(test.poses) > 1
                else "")}
    return make_log(cols, device=device.name, rate_hz=rate_hz, seed=None,
                    experiment=f"plan_constant_velocity_{test.strategy}", options=options)


def run_plan(args) -> int:
    from tendyn.io import write_log
    from tendyn.protocols import plan_test

    conv.check_applies(args)
    if args.experiment in plan_bench.KINDS:
        conv.check_plan_relations(args)
        return plan_bench.run(args, _load_device)
    if args.experiment in plan_exciting.KINDS:
        return plan_exciting.run(args, _load_device)
    for name in ("device", "transmission"):
        if getattr(args, name) is None:
            raise UsageError("required for `plan constant-velocity`", name)
    dev = cable_device(args.device, "to plan a constant-velocity test for", drives=True)
    test = plan_test(dev, args.transmission, args.strategy, args.speeds, args.travel, args.accel, args.q0,
                     args.loads)
    log = plan_constant_velocity(dev, test, args.rate)
    write_log(log, args.out)
    summary = {"out": str(args.out), "device": dev.name, "samples": log.n_samples,
               "duration_s": float(log.time[-1]), **log.meta["options"]}
    if args.json:
        _print_json(summary)
    else:
        held = summary.get("held_motors", summary.get("held_joints"))
        what = "motors" if "held_motors" in summary else "joints"
        print(f"{args.out}: {log.n_samples} samples, {summary['duration_s']:.1f} s; transmission "
              f"{args.transmission} ({args.strategy}), held {what}: {', '.join(map(str, held)) or 'none'}; "
              f"{len(test.poses)} pose(s), motor load "
              f"{', '.join(f'{x:+.3g}' for x in test.load_motor)} N·m; travel {test.travel:.3g} rad")
        for note in test.notes:
            print(f"  note: {note}")
    return 0


# ---- identify-friction ----------------------------------------------------------------------------------

def add_identify_friction_arguments(subparsers) -> argparse.ArgumentParser:
    """``tendyn identify-friction DEVICE LOG... --out FRICTION.json [--gravity …] [--json]``."""
    p = subparsers.add_parser("identify-friction",
                              help="fit C_m = C_m0 sgn(qd_m) + nu qd_m per transmission from constant-velocity logs")
    p.add_argument("device", help="device file (.toml) or bundled twin name")
    p.add_argument("logs", nargs="+", type=conv.existing_file, metavar="LOG",
                   help="constant-velocity logs (.csv/.parquet), one or more per transmission; every "
                        "transmission of the device must be covered")
    p.add_argument("--out", type=conv.out_path((".json",)), required=True, help="FRICTION.json to write")
    p.add_argument("--gravity", choices=("pairs", "model", "both"), default="pairs",
                   help="gravity removal: forward/backward pairs (S0, default), the device's gravity model, or both")
    p.add_argument("--min-speeds", type=conv.number(2, 1000, integer=True), default=None,
                   help="fewest distinct speeds per direction accepted (default 5, what plan writes)")
    p.add_argument("--load", choices=("auto", "fit", "none"), default="auto",
                   help="load-dependent term c_L |C_0|: fit it when the logs determine it (auto, default), always, "
                        "or never (S0's law)")
    p.add_argument("--force", action="store_true", help="use logs whose meta names another device")
    p.add_argument("--json", action="store_true", help="print FRICTION.json on stdout too")
    from tendyn.commands.history import add_record_arguments

    add_record_arguments(p)
    p.set_defaults(func=run_identify_friction)
    return p


def identify_friction(device, logs, gravity: str = "pairs", min_speeds: int | None = None, names=None,
                      load: str = "auto", force: bool = False) -> dict:
    """The FRICTION.json document of ``logs`` (:func:`tendyn.ident.friction_campaign.identify_friction`), after
    refusing a log whose meta names another device (unless ``force``); a campaign that cannot give one is a
    UsageError naming the log or transmission."""
    from tendyn.ident.friction_campaign import FrictionCampaignError, identify_friction as identify

    names = names or [f"log {k + 1}" for k in range(len(logs))]
    for name, log in zip(names, logs):
        conv.refuse_other_device(name, log.meta.get("device"), device, force)
    try:
        return identify(device, logs, gravity, min_speeds, names, load)
    except FrictionCampaignError as exc:
        raise UsageError(str(exc)) from None


def run_identify_friction(args) -> int:
    from tendyn.ident.friction_file import write_friction, FORMAT
    from tendyn.io import read_log

    from tendyn.commands.history import check_record, record_result

    dev = cable_device(args.device, "to identify friction of", drives=True)
    if dev.n_transmissions:
        _separable(dev, "the S0 friction identification")
    check_record(args)
    logs = [read_log(p) for p in args.logs]
    doc = identify_friction(dev, logs, args.gravity, args.min_speeds, names=[str(p) for p in args.logs],
                            load=args.load, force=getattr(args, "force", False))
    write_friction(doc, args.out)
    record_result(args, dev, "identify-friction", doc, source=", ".join(str(p) for p in args.logs))
    if args.json:
        _print_json(doc)
    else:
        print(f"{dev.name}: friction identified ({FORMAT}) -> {args.out}")
        print(friction_table(doc))
    return 0


def friction_table(doc) -> str:
    """The paper-like table of a FRICTION.json document."""
    lines = [f"{'tr':<4}{'strategy':<10}{'C_m0 [N·m]':>12}{'σ':>11}{'%σ':>7}{'ν [N·m·s/rad]':>15}{'σ':>11}"
             f"{'%σ':>7}{'c_L [-]':>10}{'%σ':>7}{'bound [N·m]':>13}"]
    warnings = []
    for f in doc["fits"]:
        b = f.get("residual_bound")
        pct = lambda x: float("nan") if x is None else x   # noqa: E731
        cl = f"{f['load_coefficient']:.4g}" if f.get("load_identified") else "—"
        lines.append(f"{f['transmission']:<4}{str(f.get('strategy')):<10}{f['coulomb_motor']:>12.5g}"
                     f"{f['coulomb_motor_std']:>11.3g}{pct(f.get('coulomb_motor_rel_std_pct')):>7.2f}"
                     f"{f['viscous_motor']:>15.5g}{f['viscous_motor_std']:>11.3g}"
                     f"{pct(f.get('viscous_motor_rel_std_pct')):>7.2f}{cl:>10}"
                     f"{pct(f.get('load_coefficient_rel_std_pct')):>7.2f}{'—' if b is None else f'{b:.3g}':>13}")
        warnings += f.get("warnings", [])
        for key, name in (("coulomb_motor", "C_m0"), ("viscous_motor", "ν")):
            if f[key] < 0:
                warnings.append(f"transmission {f['transmission']}: {name} = {f[key]:.3g} is negative: not a loss; "
                                "a compensator refuses it (check the logs' torque sign and units)")
    return "\n".join(lines + [f"warning: {w}" for w in warnings])


# ---- decompose ---------------------------------------------------------------------------------------

def add_decompose_arguments(subparsers) -> argparse.ArgumentParser:
    """``tendyn decompose DEVICE FRICTION.json [--shares FILE] [--json]``."""
    p = subparsers.add_parser("decompose", help="per-branch friction from the global values (S0 eqs. 18–21)")
    p.add_argument("device", help="device file (.toml) or bundled twin name")
    p.add_argument("friction", type=conv.existing_file, metavar="FRICTION.json", help="identified global friction")
    p.add_argument("--shares", type=conv.existing_file, default=None,
                   help="loss shares p, p' per branch (JSON, tendyn.shares/1); default: from the device's "
                        "construction (pulleys and bearings per link)")
    p.add_argument("--force", action="store_true", help="use a FRICTION.json whose document names another device")
    p.add_argument("--json", action="store_true", help="print the decomposition as JSON on stdout")
    p.set_defaults(func=run_decompose)
    return p


def run_decompose(args) -> int:
    from tendyn.commands.shared import calibrated
    from tendyn.ident.decomposition import decompose_friction

    dev = cable_device(args.device, "to decompose friction into", drives=True)
    if not dev.n_transmissions and args.shares is not None:
        raise UsageError(f"{dev.name} has capstan drives: one cable stretch each, no branches to share", "shares")
    if dev.n_transmissions:
        _separable(dev, "the loss decomposition")
    cal = calibrated(dev, args.friction, shares=args.shares, force=getattr(args, "force", False), physical=True)
    if cal.friction is None:
        raise UsageError(f"{args.friction}: format: decompose splits identify-friction's FRICTION.json "
                         "(tendyn.friction/1)")
    out = decompose_friction(cal)
    if args.json:
        _print_json(out if isinstance(out, dict) else out.to_dict())
    elif isinstance(out, dict):
        _print_drives(out)
    else:
        print(out.table())
    return 0


def _print_drives(out) -> None:
    print(f"{out['device']}: {out['note']}")
    print(f"{'drive':<7}{'joint':>6}{'N':>8}{'C_m0 [N·m]':>13}{'ν [N·m·s/rad]':>15}{'N·C_m0 [N·m]':>14}"
          f"{'N²ν [N·m·s/rad]':>17}")
    for r in out["drives"]:
        print(f"{r['name']:<7}{r['joint']:>6}{r['ratio']:>8.3g}{r['coulomb_motor']:>13.4g}{r['viscous_motor']:>15.4g}"
              f"{r['coulomb_joint']:>14.4g}{r['viscous_joint']:>17.4g}")


def register(subparsers) -> None:
    """Register the three commands (found by :func:`tendyn.cli.build_parser`)."""
    add_plan_arguments(subparsers)
    add_identify_friction_arguments(subparsers)
    add_decompose_arguments(subparsers)


if __name__ == "__main__":   # a stand-alone entry until cli.py wires the commands in
    parser = argparse.ArgumentParser(prog="tendyn")
    register(parser.add_subparsers(dest="command", required=True))
    a = parser.parse_args()
    try:
        sys.exit(a.func(a))
    except UsageError as e:
        print(f"tendyn: error: {e}", file=sys.stderr)
        sys.exit(2)
