"""The twins and the expensive runs the checks share, each computed once per :class:`~tendyn.claims.Context`.

The settings are the test suite's (the bands were set on them); ``ctx.quick`` selects cheaper ones only where
a check's band was verified to hold with them."""

from __future__ import annotations

import numpy as np

# L-EXOS constant-velocity tests: five speeds [rad/s] over 8 rad of motor travel (~15 s for the 8 runs)
FRICTION_SPEEDS = (4.0, 6.0, 8.0, 10.0, 12.0)
FRICTION_TRAVEL = 8.0


def lexos(ctx):
    from tendyn.device import load_device
    from tendyn.devices import bundled

    return ctx.get("lexos", lambda: load_device(bundled("lexos")))


def lexos_compiled(ctx):
    from tendyn.device import compile_device

    return ctx.get("lexos_compiled", lambda: compile_device(lexos(ctx)))


def friction_comparison(ctx):
    """S1 and S2 constant-velocity runs on every L-EXOS transmission, fitted from the logs alone (C7–C9)."""
    from tendyn.pipelines import s0_friction as sf

    return ctx.get("friction", lambda: sf.compare_strategies(lexos(ctx), speeds=FRICTION_SPEEDS,
                                                             travel_motor=FRICTION_TRAVEL, seed=0, keep_runs=True))


def fig7(ctx):
    """S0 Fig. 7 hand runs on L-EXOS: gravity only, k = 0.9 and (full mode) the over-compensated k = 1.2."""
    from tendyn.pipelines.s0_compensation import Fig7Result, hand_run

    def make():
        lx = lexos_compiled(ctx)
        g, c = hand_run(lx, 0.0, seed=7), hand_run(lx, 0.9, seed=7)
        over = [] if ctx.quick else [hand_run(lx, 1.2, seed=7)]
        return Fig7Result(g, c, over, [], device=lx.name)

    return ctx.get("fig7", make)


def hypotheses(ctx):
    from tendyn.pipelines.s0_hypotheses import hypotheses_experiment

    return ctx.get("hypotheses", lambda: hypotheses_experiment(lexos_compiled(ctx)))


def mcgill(ctx):
    from tendyn.device.tendon_bench import load_tendon_bench
    from tendyn.devices import bundled

    return ctx.get("mcgill", lambda: load_tendon_bench(bundled("mcgill_bench")))


def s1_params(ctx):
    from tendyn.analysis import s1_plant

    return ctx.get("s1_params", lambda: s1_plant.PlantParams.from_bench(mcgill(ctx)))


def s1_report(ctx):
    """``run_s1(mcgill_bench, quick=True)``: the S1Report of `tendyn pipeline s1 --quick` (its summary is
    :func:`s1_json`; the test suite's HTML report publishes the report itself)."""
    from tendyn.pipelines.s1 import run_s1

    return ctx.get("s1_report", lambda: run_s1(mcgill(ctx), quick=True))


def s1_json(ctx):
    """The document `tendyn pipeline s1 --json --quick` prints, computed by the library it calls
    (:func:`tendyn.pipelines.s1.run_s1` on the McGill twin, C21–C28): the claims check the library, the command
    line only calls them. The run is :func:`s1_report`'s (one run per context, not one per use)."""
    def make():
        import json

        from tendyn.io import to_jsonable

        return json.loads(json.dumps(to_jsonable(dict(s1_report(ctx).summary))))

    return ctx.get("s1_json", make)


def cea(ctx):
    from tendyn.device import load_device
    from tendyn.devices import bundled

    return ctx.get("cea", lambda: load_device(bundled("cea_branch")))


def cea_compiled(ctx):
    from tendyn.device import compile_device

    return ctx.get("cea_compiled", lambda: compile_device(cea(ctx)))


def s2_report(ctx):
    """`run_s2(quick=True, seed=0)` on the CEA twin (~40 s; C31–C40)."""
    from tendyn.pipelines.s2 import run_s2

    return ctx.get("s2_report", lambda: run_s2(cea(ctx), quick=True, seed=0))


def s2_truth(ctx):
    """Base parameters of the CEA twin from its file's standard parameters, regrouped numerically (an oracle
    independent of the identification model's)."""
    def make():
        from tendyn.device.closed_loop import base_parameters, drive_parameters
        from tendyn.device.rigid_body import standard_parameters

        d = cea(ctx)
        bp = base_parameters(d, n_samples=120, seed=3)
        return bp.values(np.concatenate([standard_parameters(d)[1], drive_parameters(d)[1]]))

    return ctx.get("s2_truth", make)


def operational_model(ctx):
    from tendyn.analysis.operational import OperationalModel

    return ctx.get("op_model", lambda: OperationalModel(cea_compiled(ctx)))


def natural_pose(ctx):
    from tendyn.analysis.operational import natural_pose as nat

    return ctx.get("q_nat", lambda: nat(operational_model(ctx)))


def maps(ctx):
    """Operational maps of the CEA twin's true parameters on the default ±50 mm grid, 5 points per axis."""
    from tendyn.analysis.operational import operational_maps

    return ctx.get("maps", lambda: operational_maps(operational_model(ctx), points=5, workspace=False))


def s2_compensation(ctx):
    """S2 §VII compensation on the CEA twin from its true parameters, k = 0 and 0.8 (C46)."""
    from tendyn.pipelines.s2_compensation import compensation_from_identified

    return ctx.get("s2_comp", lambda: compensation_from_identified(cea_compiled(ctx), None, factors=(0.0, 0.8),
                                                                   quick=True, q_natural=natural_pose(ctx)))
