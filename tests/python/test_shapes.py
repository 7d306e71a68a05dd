"""One base type for every device kind, result objects of one shape, a device compiled once, and the
import rules between the subpackages (issue 6, items 6–9)."""

import ast
import json
import math
import pathlib
import pickle

import matplotlib
import numpy as np
import pytest

import tendyn
from tendyn.device import (EXPERIMENTS, CompiledDevice, Device, SerialDevice, TendonBench, TransmissionSpec,
                           compile_device, load_device)
from tendyn.devices import bundled
from tendyn.results import FrequencyResponse, Result
from tendyn.sim import experiments as ex
from tendyn.sim import tendon_bench as tb

PACKAGE = pathlib.Path(tendyn.__file__).resolve().parent


@pytest.fixture(scope="module")
def lexos():
    return load_device(bundled("lexos"))


@pytest.fixture(scope="module")
def bench():
    return load_device(bundled("mcgill_bench"))


# ---- one base type ---------------------------------------------------------------------------------

@pytest.mark.parametrize("name, cls, kind", [("lexos", SerialDevice, "serial"), ("cea_branch", SerialDevice, "serial"),
                                             ("mcgill_bench", TendonBench, "tendon_bench_2n")])
def test_every_device_kind_shares_the_base(name, cls, kind):
    dev = load_device(bundled(name))
    assert isinstance(dev, Device) and type(dev) is cls
    assert dev.kind == kind
    assert isinstance(dev.name, str) and dev.name
    assert dev.path == bundled(name).resolve() or dev.path == bundled(name)
    assert dev.source == str(dev.path)
    assert dev.experiments and set(dev.experiments) <= set(EXPERIMENTS)


def test_experiments_tell_a_bench_from_an_arm(lexos, bench):
    # what the CLI checks, without knowing any class
    assert lexos.supports("constant-velocity") and not lexos.supports("low-speed-loop")
    assert bench.supports("low-speed-loop") and not bench.supports("constant-velocity")
    with pytest.raises(ValueError, match="stepped-sine"):
        bench.check_experiment("blocked-link")
    lexos.check_experiment("blocked-link")


def test_one_name_per_public_class():
    """No two public classes of the package share a name (the device-file entry is TransmissionSpec)."""
    import importlib
    import pkgutil

    owners = {}
    for info in pkgutil.walk_packages([str(PACKAGE)], "tendyn."):
        if info.name.startswith("tendyn._") or "._" in info.name or info.name.endswith("cli"):
            continue
        mod = importlib.import_module(info.name)
        for key, obj in vars(mod).items():
            if isinstance(obj, type) and not key.startswith("_") and obj.__module__ == mod.__name__:
                owners.setdefault(key, []).append(mod.__name__)
    shared = {k: v for k, v in owners.items() if len(v) > 1}
    assert not shared, shared
    assert TransmissionSpec.__module__ == "tendyn.device.schema_parts"      # its owner; the schema face re-exports it


# ---- results of one shape ----------------------------------------------------------------------------

@pytest.fixture
def other_backend():
    """Switch to a backend no plot() would pick, so that a plot() that selects one is seen."""
    before = matplotlib.get_backend()
    matplotlib.use("svg")
    yield "svg"
    matplotlib.use(before)


def _results(lexos, bench):
    from tendyn.pipelines.bench_frf import bench_frf
    from tendyn.pipelines.friction_sweep import FrictionSweep
    from tendyn.pipelines.statics_demo import statics_demo

    omega = 2 * math.pi * np.array([10.0, 15.0, 20.0])
    sweep = FrictionSweep("L-EXOS", 1, {"S1": (np.array([2.0, -2.0]), np.array([0.01, -0.01]))})
    return {
        "stepped": tb.stepped_sine(bench, omega=omega, amplitude_N=0.6, cycles=2, settle_cycles=2, settle_s=0.0),
        "swept": tb.swept_sine(bench, f0_hz=5.0, f1_hz=30.0, duration_s=1.0, amplitude_N=1.0, tail_s=0.2),
        "loop": tb.low_speed_loop(bench, freq_hz=2.0, amplitude_N=0.5, cycles=1, settle_cycles=0),
        "peak": tb.resonance_peak(bench, 0.6, f_lo=10.0, f_hi=20.0, step_hz=5.0, refine_hz=0.0, cycles=2,
                                  settle_cycles=2, settle_s=0.0),
        "bench_frf": bench_frf(bench, amplitudes=(0.6,), omega=omega),
        "statics": statics_demo(lexos, joints=(0, 3), points=5),
        "friction_sweep": sweep,
        **_ident_results(lexos),
    }


def _ident_results(lexos):
    """The S0 friction results (issue 8), built from small made-up fits (no simulation here)."""
    from tendyn.ident import FrictionFit, decompose
    from tendyn.pipelines.s0_friction import StrategyComparison

    v = np.array([2.0, 4.0, 6.0, 8.0, 10.0])
    cmp = StrategyComparison("L-EXOS", list(v))
    for t in range(1, 5):
        for k, s in enumerate(("S1", "S2")):
            c0, nu = 0.008 * t * (1.1 - 0.1 * k), 6.4e-4 * t
            pts = np.column_stack([v, c0 + nu * v, np.full(5, 100.0)])
            cmp.fits[(t, s)] = FrictionFit(t, c0, nu, 1e-4, 1e-5, 1e-3, 10.0, s, "pairs", list(v), 5, pts)
        cmp.truth[t] = (0.008 * t, 6.4e-4 * t)
    dec = decompose(lexos, [cmp.truth[t][0] for t in range(1, 5)], [cmp.truth[t][1] for t in range(1, 5)])
    return {"friction_fit": cmp.fits[(2, "S2")], "s0_comparison": cmp, "loss_decomposition": dec}


@pytest.fixture(scope="module")
def results(lexos, bench):
    return _results(lexos, bench)


def test_plot_draws_into_given_axes_and_returns_its_figure(results, other_backend):
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure

    figs_before = plt.get_fignums()
    for name, res in results.items():
        assert isinstance(res, Result), name
        n = res._panels
        fig = Figure()
        axes = fig.subplots(1, n, squeeze=False)[0]
        given = axes[0] if n == 1 else list(axes)
        out = res.plot(given)
        assert out is fig, name
        assert any(a.lines for a in axes), name          # it drew into the given axes
        new = res.plot()                                  # and into a new figure when none is given
        assert isinstance(new, Figure) and new is not fig and any(a.lines for a in new.axes), name
        assert matplotlib.get_backend() == other_backend, f"{name}.plot switched the backend"
    assert plt.get_fignums() == figs_before               # no pyplot figure was made


def test_a_frequency_response_overlays_on_one_axes(results):
    from matplotlib.figure import Figure

    ax = Figure().subplots()
    results["stepped"].plot(ax)
    results["swept"].plot(ax)
    assert len(ax.lines) == 2


def test_to_dict_is_json_and_table_prints(results):
    for name, res in results.items():
        doc = json.loads(json.dumps(res.to_dict()))
        assert isinstance(doc, dict) and doc, name
        text = res.table()
        assert isinstance(text, str) and len(text.splitlines()) >= 3, name
        assert str(res) == text


def test_save_png_of_a_result(results, tmp_path):
    from tendyn.io import save_png

    path = save_png(results["stepped"].plot(), tmp_path / "frf.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# ---- one frequency-response class ---------------------------------------------------------------------

def test_one_frequency_response_for_stepped_and_swept_bench_and_chain(lexos, results):
    chain_stepped = ex.stepped_sine_response(lexos, 1, omega=2 * math.pi * np.array([2.0, 4.0]), amplitude=0.05,
                                             cycles=4, rate_hz=5_000.0, control_hz=5_000.0)
    chain_swept = ex.swept_sine_response(lexos, 1, 0.05, f0_hz=1.0, f1_hz=8.0, duration=2.0, rate_hz=5_000.0)
    for frf in (results["stepped"], results["swept"], chain_stepped, chain_swept):
        assert type(frf) is FrequencyResponse
        assert frf.omega.shape == frf.ratio.shape and np.iscomplexobj(frf.ratio)
        np.testing.assert_allclose(frf.freq_hz, frf.omega / (2 * math.pi))
        np.testing.assert_allclose(frf.magnitude, np.abs(frf.ratio))
        assert frf.peak_hz() == pytest.approx(frf.freq_hz[np.argmax(frf.magnitude)])
    # the grids are rad/s: the swept sines span their (f0_hz, f1_hz) band
    swept = results["swept"]
    assert 5.0 < swept.freq_hz.min() < 6.0 and 29.0 < swept.freq_hz.max() < 30.0
    assert 1.0 < chain_swept.freq_hz.min() < 2.0 and 7.0 < chain_swept.freq_hz.max() < 8.0
    np.testing.assert_allclose(chain_stepped.omega, 2 * math.pi * np.array([2.0, 4.0]))
    # links free, torque in, motor angle out: inertia and damping, so the angle lags by more than 90°
    # and the magnitude falls with frequency
    assert np.all((chain_stepped.phase_deg < -90.0) & (chain_stepped.phase_deg > -180.0))
    assert chain_stepped.magnitude[1] < 0.6 * chain_stepped.magnitude[0]
    assert chain_swept.unit == chain_stepped.unit == "rad/(N·m)" and len(chain_stepped.runs) == 2


def test_frequency_grids_are_omega_and_keyword_only(bench):
    with pytest.raises(TypeError):
        tb.stepped_sine(bench, [10.0], 0.5)          # an old Hz grid given positionally fails loudly
    res = tb.stepped_sine(bench, omega=[2 * math.pi * 10.0], amplitude_N=0.6, cycles=1, settle_cycles=1,
                          settle_s=0.0)
    assert res.freq_hz[0] == pytest.approx(10.0)


# ---- compiled once ------------------------------------------------------------------------------------

def test_compile_device_is_cached_and_idempotent(lexos, bench):
    cd = compile_device(lexos)
    assert isinstance(cd, CompiledDevice) and cd.device is lexos
    assert compile_device(lexos) is cd and compile_device(cd) is cd
    assert (cd.name, cd.kind, cd.experiments) == (lexos.name, lexos.kind, lexos.experiments)
    L, c = cd.active_map
    np.testing.assert_array_equal(L, np.eye(4))
    assert cd.transmission is not None and cd.transmission.n == 4
    cb = compile_device(bench)
    assert cb.transmission is None and cb.device is bench
    with pytest.raises(ValueError, match="tendon_bench_2n"):
        cb.pinocchio_model
    with pytest.raises(TypeError):
        compile_device("lexos")
    clone = pickle.loads(pickle.dumps(lexos))     # the cache does not travel with a pickle
    assert compile_device(clone) is not cd and compile_device(clone).device is clone


def test_closed_loop_map_comes_from_the_constraints():
    cea = load_device(bundled("cea_branch"))
    L, c = compile_device(cea).active_map
    assert L.shape[0] > L.shape[1]                    # passive joints are determined by the active ones


def test_one_constant_velocity_run_builds_the_rigid_body_once(monkeypatch):
    import pinocchio as pin

    from tendyn import _core

    counts = {"pinocchio.Model": 0, "_core.RigidBodyModel": 0}

    def counting(name, real):
        def make(*a, **kw):
            counts[name] += 1
            return real(*a, **kw)
        return make

    monkeypatch.setattr(pin, "Model", counting("pinocchio.Model", pin.Model))
    monkeypatch.setattr(_core, "RigidBodyModel", counting("_core.RigidBodyModel", _core.RigidBodyModel))
    dev = load_device(bundled("lexos"))               # a fresh device: nothing compiled yet
    ex.constant_velocity(dev, 2, [6.0], strategy="S2", travel=2.0, q0=[0.0, 0.3, 0.0, 0.8])
    assert counts == {"pinocchio.Model": 1, "_core.RigidBodyModel": 1}
    ex.constant_velocity(dev, 2, [6.0], strategy="S1", travel=2.0, q0=[0.0, 0.3, 0.0, 0.8])
    ex.blocked_link(dev, 1, 0.05, period=0.2, cycles=1)
    assert counts == {"pinocchio.Model": 1, "_core.RigidBodyModel": 1}   # later runs reuse the compiled device


# ---- import rules (DESIGN: who may import whom) ------------------------------------------------------

# The rules are the one table of docs/architecture.md ("Layers: who may import whom"), read by
# tests/python/test_architecture.py, which also checks every module for circles; here, per package: its own
# modules, the leaves (floor 0) and the packages its row names.
from test_architecture import layers as _layers  # noqa: E402

_TABLE = _layers()
_LEAVES = {p for p, (floor, _) in _TABLE.items() if floor == 0}
ALLOWED = {sub: {sub, *allowed} | _LEAVES for sub, (floor, allowed) in _TABLE.items()
           if (PACKAGE / sub).is_dir() or (PACKAGE / f"{sub}.py").exists()}


def _tendyn_imports(path: pathlib.Path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    pkg = path.relative_to(PACKAGE).parts
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = list(("tendyn",) + pkg[:-1])[: len(pkg) + 1 - node.level]
                names = [".".join(base + ([node.module] if node.module else []))]
                if not node.module:
                    names = [".".join(base + [a.name]) for a in node.names]
            else:
                names = [node.module]
        else:
            continue
        for n in names:
            if n == "tendyn":
                yield from (a.name for a in node.names)
            elif n.startswith("tendyn.device.schema"):
                yield "device.schema"       # the leaf of declarations (field tables), told apart
            elif n.startswith("tendyn."):
                yield n.split(".")[1]


@pytest.mark.parametrize("sub", sorted(ALLOWED))
def test_import_rules(sub):
    where = PACKAGE / sub
    files = sorted(where.rglob("*.py")) if where.is_dir() else [PACKAGE / f"{sub}.py"]
    bad = {(f.name, t) for f in files for t in _tendyn_imports(f)
           if t not in ALLOWED[sub] and t.split(".")[0] not in ALLOWED[sub] and t not in ("devices", "__version__")}
    assert not bad, f"tendyn.{sub} imports {sorted(bad)}"


def test_the_schema_is_a_leaf():
    """transmission.py may read the parameter declarations of device/schema.py because schema imports nothing
    of tendyn: no circle device → transmission → device can form. The schema is a face over its parts (issue 33
    item 4): the face and each part import only the device's base class, its term limits and one another."""
    family = ["schema.py", "schema_fields.py", "schema_parts.py", "core_fields.py", "serial_device.py"]
    for name in family:
        assert set(_tendyn_imports(PACKAGE / "device" / name)) <= {"device", "device.schema"}, name
    assert list(_tendyn_imports(PACKAGE / "device" / "base.py")) == []
