"""`tendyn maps DEVICE [PARAMS.json] [--friction FRICTION.json] [--json] [--report DIR]`: apparent mass, friction
and stiffness felt at the handle over the workspace.

Capstan drives (``[[drives]]``, the CEA branch): from identified base parameters over a Cartesian grid around the
natural pose (S2 §VII, C41–C45; :mod:`tendyn.analysis.operational`; PARAMS.json required). Cable transmissions
and geared actuators (``[[transmissions]]``, ``[[actuators]]``): over a grid of the joint limits, inertia from the
device file or PARAMS.json, friction from the device file or FRICTION.json (:mod:`tendyn.analysis.handle_maps`)."""

from __future__ import annotations

import numpy as np

from tendyn.commands.args import existing_file, number, numbers
from tendyn.errors import UsageError


def register(subparsers) -> None:
    p = subparsers.add_parser("maps", help="apparent mass, friction and stiffness at the handle over the workspace")
    p.add_argument("device", help="device file (.toml) or bundled twin: cable transmissions (lexos), geared "
                                  "actuators (tx40) or capstan drives (cea_branch)")
    p.add_argument("params", type=existing_file, metavar="PARAMS.json", nargs="?", default=None,
                   help="base parameters: the document of `tendyn identify --json` (or --out); required for capstan "
                        "drives, else the inertia [default: the device file's links and rotors]")
    p.add_argument("--friction", type=existing_file, metavar="FRICTION.json", default=None,
                   help="identified friction per transmission (`tendyn identify-friction --out`) [default: the "
                        "device file's loss model at zero load]; cable devices")
    p.add_argument("--stiffness", type=numbers(0.0, lo_open=True, unit="N·m/rad"), default=None, metavar="K1,K2,…",
                   help="capstan stiffness K_T per drive, motor side [N·m/rad] [default: the device's]")
    p.add_argument("--half-width", type=number(0.0, 0.5, lo_open=True, unit="m"), default=None,
                   help="half-width of the grid cube around the natural pose [m] [default: 0.05]")
    p.add_argument("--points", type=number(2, 41, integer=True), default=None,
                   help="capstan drives: Cartesian grid points per axis, odd [default: 11]; cable and geared: grid "
                        "points per active joint [default: ⌊2000^(1/n)⌋ within 2–21]")
    p.add_argument("--report", default=None, metavar="DIR",
                   help="write report.html, the figures (fig8.png, fig9.png; handle_maps.png), maps.json and maps.txt "
                        "into DIR")
    p.add_argument("--json", action="store_true", help="print one JSON document on stdout")
    p.add_argument("--force", action="store_true", help="use a PARAMS.json or FRICTION.json whose document names another device")
    p.set_defaults(func=run)


def run(args) -> int:
    from tendyn.analysis.operational import (DEFAULT_HALF_WIDTH, DEFAULT_POINTS, OperationalModel, ParamsError,
                                             operational_maps)
    from tendyn.commands.shared import calibrated, check_out_folder as _check_out_folder, load as _load
    from tendyn.report import publish

    dev = _load(args.device)
    if dev.kind == "serial" and not dev.drives and (dev.transmissions or dev.actuators):
        return _run_handle(args, dev)
    if dev.kind != "serial" or not dev.drives:
        raise UsageError(f"{dev.name} is a {dev.kind} device without transmissions, actuators or capstan drives: "
                         "it has no handle to map", "device")
    if args.params is None:
        raise UsageError(f"PARAMS.json: missing; {dev.name} has capstan drives, whose maps need the identified base "
                         "parameters (`tendyn identify --out`)")
    if args.friction is not None:
        raise UsageError(f"applies to cable transmissions; {dev.name}'s capstan friction is in PARAMS.json",
                         "friction")
    points = DEFAULT_POINTS if args.points is None else args.points
    if points % 2 == 0:
        raise UsageError(f"must be odd, so that the lines through the natural pose are on the grid (got {points})",
                         "points")
    if args.stiffness is not None and len(args.stiffness) != len(dev.drives):
        raise UsageError(f"needs one value per drive of {dev.name}: {len(dev.drives)} values (got "
                         f"{len(args.stiffness)})", "stiffness")
    out = _check_out_folder(args.report, "report") if args.report else None
    # the device with its identified values: PARAMS.json read once (device and file version checked unless
    # --force), the capstan stiffness laid over the file's per drive
    cal = calibrated(dev, params=args.params, stiffness=args.stiffness, force=args.force)
    try:
        model = OperationalModel(cal.compiled, cal.params, force=args.force)
        refuse_impossible_inertia(model.mass_matrix, model.handle, args.params)
    except ParamsError as exc:
        where = ": ".join(p for p in (exc.file or str(args.params), exc.field) if p)
        raise UsageError(f"{where}: {exc.problem}") from None
    from tendyn.progress import Ticker

    maps = operational_maps(model, half_width=DEFAULT_HALF_WIDTH if args.half_width is None else args.half_width,
                            points=points, progress=Ticker("maps"))
    doc = maps.to_dict()
    doc["params_file"] = str(args.params)
    doc["sources"] = dict(cal.sources)
    return publish(args, doc, maps.table(), maps.figures, out, "maps.json", "maps.txt", command="maps", device=dev,
                   logs=[p for p in (args.params, args.friction) if p is not None],
                   title=f"Maps of {dev.name} at the handle")


def _run_handle(args, dev) -> int:
    """Cable transmissions or geared actuators: the maps of :mod:`tendyn.analysis.handle_maps`."""
    from tendyn.analysis.handle_maps import handle_maps
    from tendyn.commands.shared import calibrated, check_out_folder as _check_out_folder
    from tendyn.report import publish

    for opt in ("stiffness", "half_width"):
        if getattr(args, opt) is not None:
            raise UsageError(f"applies to capstan drives only; {dev.name} has "
                             f"{'cable transmissions' if dev.transmissions else 'geared actuators'}", opt)
    out = _check_out_folder(args.report, "report") if args.report else None
    if args.friction is not None and not dev.transmissions:
        raise UsageError(f"FRICTION.json gives friction per cable transmission; {dev.name} has none", "friction")
    # the device with its identified values, each document read once; on a differential FRICTION.json holds the
    # motors' values, which the maps take as they are (no per-branch split needed)
    cal = calibrated(dev, friction=args.friction, params=args.params, force=args.force, physical=True)
    kw, sources = {}, {}
    if args.friction is not None:
        if cal.friction is None:
            raise UsageError(f"{args.friction}: the maps take identify-friction's FRICTION.json (tendyn.friction/1)",
                             "friction")
        kw.update(coulomb_motor=cal.friction["coulomb_motor"], viscous_motor=cal.friction["viscous_motor"])
        sources["friction"] = f"{cal.sources['friction']} ({cal.friction['format']})"   # the calibration's record
    if args.params is not None:
        kw["mass_matrix"] = _identified_mass_matrix(cal, args.params)
        sources["inertia"] = f"{cal.sources['params']} (base parameters, rotor terms included)"
    try:
        from tendyn.progress import Ticker

        maps = handle_maps(dev, points=args.points, sources=sources, progress=Ticker("maps"), **kw)
    except ValueError as exc:      # a device whose handle cannot be mapped (no motor per joint, always singular)
        raise UsageError(str(exc), "device") from None
    doc = maps.to_dict()
    doc["params_file"] = None if args.params is None else str(args.params)
    doc["friction_file"] = None if args.friction is None else str(args.friction)
    return publish(args, doc, maps.table(), maps.figures, out, "maps.json", "maps.txt", command="maps", device=dev,
                   logs=[p for p in (args.params, args.friction) if p is not None],
                   title=f"Maps of {dev.name} at the handle")


def _identified_mass_matrix(cal, path):
    """q ↦ A(q) [kg·m²] from the base parameters of the calibrated device (PARAMS.json at ``path``, read once),
    through the identification model's regressor."""
    from tendyn.analysis.handle_point import HandlePoint
    from tendyn.analysis.operational import ParamsError, read_params
    from tendyn.ident import IdentModel

    dev = cal.device
    model = IdentModel(dev)
    try:
        params = read_params(cal.params, dev, cal.force, standard_names=model.standard_names,
                             base_names=model.base.names)
    except ParamsError as exc:
        where = ": ".join(p for p in (exc.file or str(path), exc.field) if p)
        raise UsageError(f"{where}: {exc.problem}") from None
    try:
        x = model.parameter_vector(params)
    except ValueError as exc:
        raise UsageError(f"{path}: {exc}") from None
    refuse_impossible_inertia(lambda q: model.mass_matrix(q, x), HandlePoint(cal.compiled), path)
    return lambda q: model.mass_matrix(q, x)


def refuse_impossible_inertia(mass_matrix, handle, path) -> None:
    """Refuse identified parameters whose joint mass matrix A(q) [kg·m²] is not positive definite at the middle of
    the joint limits: the kinetic energy ½ q̇ᵀ A q̇ of a real device is positive, so all-zero or negative inertias
    are impossible (the maps would report 0 kg, or |eigenvalues| of a negative matrix as kilograms)."""
    lo, hi = handle.active_limits()
    q = np.where(np.isfinite(lo) & np.isfinite(hi), 0.5 * (lo + hi), 0.0)
    A = np.asarray(mass_matrix(q), float)
    smallest = float(np.linalg.eigvalsh(0.5 * (A + A.T)).min()) if np.all(np.isfinite(A)) else float("nan")
    if not smallest > 0.0:
        raise UsageError(f"{path}: the parameters give a joint mass matrix that is not positive definite at "
                         f"q = {np.round(q, 3).tolist()} rad (smallest eigenvalue {smallest:.3g} kg·m²): "
                         "physically impossible inertias (zero or negative)")
