"""`tendyn plan exciting DEVICE --out REF.csv`: an optimised exciting trajectory for identification (issue 18
item 7): a finite Fourier series per active joint minimising cond(W) of the base regressor inside the joint,
speed and motor-torque limits (:func:`tendyn.ident.exciting.plan_exciting`), written as joint references
``q_ref_<k>``, ``qd_ref_<k>``; cond(W) reported. The `plan` subparser belongs to
:mod:`tendyn.commands.s0`; it adds these options with :func:`add_arguments` and hands the kind to :func:`run`.
"""

from __future__ import annotations

import argparse

from tendyn.commands import args as conv
from tendyn.errors import UsageError

KINDS = ("exciting",)


def add_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("exciting (an optimised Fourier trajectory for identification)")
    g.add_argument("--harmonics", type=conv.number(1, 20, integer=True), default=5,
                   help="harmonics per joint (default 5)")
    g.add_argument("--base-hz", type=conv.number(0.0, 100.0, lo_open=True, unit="Hz"), default=None,
                   help="fundamental f0 [Hz] (default 0.2, lowered to keep the harmonics below half the device's "
                        "bandwidth_hz)")
    g.add_argument("--max-speed", type=conv.number(0.0, 1e3, lo_open=True, unit="rad/s"), default=1.5,
                   help="speed limit per joint [rad/s, m/s at a prismatic joint] (default 1.5)")
    g.add_argument("--iterations", type=conv.number(1, 100000, integer=True), default=300,
                   help="candidates tried by the optimiser (default 300)")
    g.add_argument("--periods", type=conv.number(1, 1000, integer=True), default=3,
                   help="periods written when --duration is not given (default 3)")


def run(args, load_device) -> int:
    import json

    from tendyn.ident.exciting import plan_exciting
    from tendyn.io import to_jsonable, write_log

    if args.device is None:
        raise UsageError("required for `plan exciting`", "device")
    dev = load_device(args.device)
    if getattr(dev, "kind", None) != "serial":
        raise UsageError(f"{dev.name} is a {dev.kind}: an exciting trajectory needs a rigid serial device", "device")
    from tendyn.device.schema import require_one_per_joint

    require_one_per_joint(dev, "plan exciting (the identification's motor torque limits through G⁻ᵀ)")
    try:
        plan = plan_exciting(dev, harmonics=args.harmonics, base_hz=args.base_hz, max_speed=args.max_speed,
                             iterations=args.iterations, seed=args.seed)
    except ValueError as exc:       # the limits leave no room (a motor cannot even hold the pose)
        raise UsageError(str(exc), "device") from None
    duration = args.duration if args.duration is not None else args.periods * plan.design.period
    log = plan.reference_log(duration, args.rate, dev.name)
    write_log(log, args.out)
    summary = {"out": str(args.out), "device": dev.name, "samples": log.n_samples, "duration_s": duration,
               "rate_hz": args.rate, **plan.to_dict()}
    if args.json:
        print(json.dumps(to_jsonable(summary), indent=2, allow_nan=False))
    else:
        print(plan.table())
        print(f"{args.out}: {log.n_samples} samples, {duration:.3g} s of q_ref_1…q_ref_{plan.design.a.shape[0]}")
    return 0
