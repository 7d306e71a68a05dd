"""`tendyn maps DEVICE PARAMS.json [--json] [--report DIR] [--stiffness K1,K2,K5]`: apparent mass, friction
and stiffness felt at the handle over a workspace grid, from identified base parameters (S2 §VII, C41–C45;
:mod:`tendyn.analysis.operational`)."""

from __future__ import annotations

from tendyn.commands.args import existing_file, number, numbers
from tendyn.errors import UsageError


def register(subparsers) -> None:
    p = subparsers.add_parser("maps", help="operational maps (apparent mass, friction, stiffness) from identified "
                                           "parameters")
    p.add_argument("device", help="device file (.toml) or bundled twin with capstan drives (cea_branch)")
    p.add_argument("params", type=existing_file, metavar="PARAMS.json",
                   help="base parameters: the document of `tendyn identify --json` (or --out)")
    p.add_argument("--stiffness", type=numbers(0.0, lo_open=True, unit="N·m/rad"), default=None, metavar="K1,K2,…",
                   help="capstan stiffness K_T per drive, motor side [N·m/rad] [default: the device's]")
    p.add_argument("--half-width", type=number(0.0, 0.5, lo_open=True, unit="m"), default=None,
                   help="half-width of the grid cube around the natural pose [m] [default: 0.05]")
    p.add_argument("--points", type=number(3, 41, integer=True), default=None,
                   help="grid points per axis, odd [default: 11]")
    p.add_argument("--report", default=None, metavar="DIR", help="write fig8.png, fig9.png and maps.json into DIR")
    p.add_argument("--json", action="store_true", help="print one JSON document on stdout")
    p.set_defaults(func=run)


def run(args) -> int:
    from tendyn.analysis.operational import (DEFAULT_HALF_WIDTH, DEFAULT_POINTS, OperationalModel, ParamsError,
                                             operational_maps)
    from tendyn.cli import _check_out_folder, _load
    from tendyn.commands.pipeline import publish

    dev = _load(args.device)
    if dev.kind != "serial" or not dev.drives:
        raise UsageError(f"{dev.name} has no capstan drives ([[drives]]: ratio, K_T, K_E); the maps need them",
                         "device")
    points = DEFAULT_POINTS if args.points is None else args.points
    if points % 2 == 0:
        raise UsageError(f"must be odd, so that the lines through the natural pose are on the grid (got {points})",
                         "points")
    if args.stiffness is not None and len(args.stiffness) != len(dev.drives):
        raise UsageError(f"needs one value per drive of {dev.name}: {len(dev.drives)} values (got "
                         f"{len(args.stiffness)})", "stiffness")
    out = _check_out_folder(args.report) if args.report else None
    try:
        model = OperationalModel(dev, str(args.params), stiffness_motor=args.stiffness)
    except ParamsError as exc:
        where = ": ".join(p for p in (exc.file or str(args.params), exc.field) if p)
        raise UsageError(f"{where}: {exc.problem}") from None
    maps = operational_maps(model, half_width=DEFAULT_HALF_WIDTH if args.half_width is None else args.half_width,
                            points=points)
    doc = maps.to_dict()
    doc["params_file"] = str(args.params)
    return publish(args, doc, maps.table(), maps.figures, out, "maps.json", "maps.txt")
