"""Issue 21, item 5: the Lur'e structure of the block-model estimator (ident/blockmodel.py) — a linear block G
with Coulomb friction in its feedback, fitted by output error — on a synthetic Lur'e system of known truth.

The oracle never shares the code under test: the data come from a state-space simulation written here (the
ZOH sampling of a mass-spring-damper by python-control, the friction force solved from the velocity-level
balance of each step), not from ``blockmodel._lure_simulate`` (an input/output recursion); the estimator
sees only (u, y)."""

from __future__ import annotations

import contextlib
import io
import json

import numpy as np
import pytest

control = pytest.importorskip("control")

from tendyn.cli import main  # noqa: E402
from tendyn.ident import blockmodel as bm  # noqa: E402
from tendyn.io import make_log, write_log  # noqa: E402

RATE = 1000.0
MASS, DAMPING, STIFFNESS = 0.5, 6.0, 2.0e4          # kg, N s/m, N/m: 31.8 Hz, ζ = 0.03
FRICTION = 0.2                                      # N, Coulomb level (dead-band half-width seen from u)


def truth_G():
    """y = k x [N] for the force u [N] on the mass: G(s) = k/(m s² + c s + k), G(0) = 1, ZOH at RATE."""
    return control.sample_system(control.tf([STIFFNESS], [MASS, DAMPING, STIFFNESS]), 1 / RATE, method="zoh")


def truth_coefficients():
    Gz = truth_G()
    num, den = np.ravel(Gz.num[0][0]), np.ravel(Gz.den[0][0])
    return np.concatenate([[0.0], num / den[0]]), den[1:] / den[0]


def oracle(u, level=FRICTION):
    """The mass-spring-damper with Coulomb friction of ``level`` [N] in a state-space loop: per step, the
    friction f (held over the step like u) opposes the output's increment. If the f that holds the output
    (y_{k+1} = y_k) is within ±level, the mass sticks: the state is the equilibrium at y_k (zero velocity);
    else it slips with f = ±level."""
    ss = control.ss(truth_G())
    A, B, C = np.asarray(ss.A), np.asarray(ss.B).ravel(), np.asarray(ss.C).ravel()
    cb = float(C @ B)
    x_unit = np.linalg.solve(np.eye(A.shape[0]) - A, B)
    x_unit /= float(C @ x_unit)                       # the equilibrium state of output 1
    x = np.zeros(A.shape[0])
    y = np.zeros(len(u))
    for k in range(len(u) - 1):
        free = float(C @ (A @ x + B * u[k]))          # y_{k+1} with no friction
        f = (free - y[k]) / cb
        if abs(f) <= level:
            x = y[k] * x_unit
        else:
            x = A @ x + B * (u[k] - level * np.sign(f))
        y[k + 1] = float(C @ x)
    return y


def prbs(rng, n, amplitude=1.0, hold=25):
    """Random binary levels held ``hold`` samples, each level drawn in [0.3, 1] × amplitude [N]."""
    s = np.repeat(rng.choice([-1.0, 1.0], n // hold + 1), hold)[:n]
    return amplitude * s * np.repeat(rng.uniform(0.3, 1.0, n // hold + 1), hold)[:n]


@pytest.fixture(scope="module")
def data():
    rng = np.random.default_rng(27)
    u, uv = prbs(rng, 4000), prbs(rng, 2000, amplitude=0.8)
    return u, oracle(u), uv, oracle(uv)


def test_the_oracle_sticks_and_slips():
    """The data hold both regimes (else the friction level would not be identifiable): stuck samples
    (output unchanged) and moving ones, and a command inside the dead-band moves nothing."""
    rng = np.random.default_rng(3)
    u = prbs(rng, 3000)
    y = oracle(u)
    stuck = np.mean(np.diff(y) == 0.0)
    assert 0.05 < stuck < 0.9
    assert np.all(oracle(np.full(200, 0.9 * FRICTION)) == 0.0)
    assert np.any(oracle(np.full(200, 1.1 * FRICTION)) != 0.0)


def test_lure_recovers_the_parameters_at_no_noise(data):
    """Issue 21 item 5: G(z) and the friction level within 1 % of the truth; validation by simulation from
    rest on another record (other levels) at NRMS < 0.01."""
    u, y, uv, yv = data
    model = bm.BlockModel("lure", "coulomb", order=2, rate_hz=RATE).fit((u, y), validation=(uv, yv))
    b, a = truth_coefficients()
    assert model.b_[0] == 0.0                                   # strictly proper: the feedback needs it
    np.testing.assert_allclose(model.b_, b, rtol=0.01)
    np.testing.assert_allclose(model.a_, a, rtol=0.01)
    assert model.params_["level"] == pytest.approx(FRICTION, rel=0.01)
    assert model.validation_nrms_[0] < 0.01
    assert model.score(uv, yv) == pytest.approx(1 - model.validation_nrms_[0])
    Gs = model.result_.linear_continuous()                     # python-control objects out
    w = 2 * np.pi * np.array([2.0, 20.0, 40.0])
    G = control.tf([STIFFNESS], [MASS, DAMPING, STIFFNESS])
    np.testing.assert_allclose(np.abs(Gs(1j * w)), np.abs(G(1j * w)), rtol=0.01)


def test_lure_reaches_the_noise_floor_with_noise(data):
    """Output noise at 3 % of the output's rms: the validation NRMS against the noisy record is the noise
    floor (the truth's own NRMS) within 10 %, against the clean record far below it; the level within 5 %."""
    u, y, uv, yv = data
    rng = np.random.default_rng(8)
    sd = 0.03 * np.std(y)
    model = bm.BlockModel("lure", "coulomb", order=2, rate_hz=RATE).fit((u, y + sd * rng.standard_normal(y.size)))
    noisy = yv + sd * rng.standard_normal(yv.size)
    floor = bm.nrms(noisy, yv)
    assert model.nrms(uv, noisy) < 1.1 * floor
    assert model.nrms(uv, yv) < 0.5 * floor
    assert model.params_["level"] == pytest.approx(FRICTION, rel=0.05)


def test_wiener_and_hammerstein_cannot_hold_friction_in_the_feedback(data):
    """The reason for the structure: on the same Lur'e data, the Wiener dead-zone and the Hammerstein
    Coulomb models stay far above the Lur'e model's validation NRMS."""
    u, y, uv, yv = data
    lure = bm.BlockModel("lure", "coulomb", order=2, rate_hz=RATE).fit((u, y), validation=(uv, yv))
    for structure, name in (("wiener", "dead-zone"), ("hammerstein", "coulomb")):
        other = bm.BlockModel(structure, name, order=2, rate_hz=RATE).fit((u, y), validation=(uv, yv))
        assert other.validation_nrms_[0] > 10 * lure.validation_nrms_[0], structure


def test_lure_order_chosen_by_validation(data):
    u, y, uv, yv = data
    model = bm.BlockModel("lure", "coulomb", order=None, max_order=3, rate_hz=RATE).fit((u, y), validation=(uv, yv))
    assert model.order_ == 2 and model.order_nrms_[1] > 0.05 > model.order_nrms_[2]


def test_lure_takes_only_coulomb():
    u = np.zeros(100)
    with pytest.raises(ValueError, match="lure structure takes the nonlinearity coulomb"):
        bm.BlockModel("lure", "dead-zone", rate_hz=RATE).fit((u, u))


def run(argv):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


def test_identify_bench_structure_lure(tmp_path, data):
    """`tendyn identify-bench --structure lure --nonlinearity coulomb` on generic logs (input_1 → output_1)."""
    u, y, uv, yv = data
    signals = {"input_1": {"name": "drive", "unit": "N"}, "output_1": {"name": "tension", "unit": "N"}}
    paths = []
    for k, (uu, yy) in enumerate(((u, y), (uv, yv))):
        lg = make_log({"time": np.arange(uu.size) / RATE, "input_1": uu, "output_1": yy}, device="bench",
                      rate_hz=RATE, seed=None, experiment="prbs", signals=signals)
        paths.append(write_log(lg, tmp_path / f"r{k}.csv"))
    code, out, err = run(["identify-bench", str(paths[0]), "--structure", "lure", "--nonlinearity", "coulomb",
                          "--order", "2", "--validate", str(paths[1]), "--json"])
    assert code == 0, err
    doc = json.loads(out)
    assert doc["structure"] == "lure" and doc["nonlinearity_params"]["level"] == pytest.approx(FRICTION, rel=0.01)
    assert doc["validation_nrms"][0] < 0.01
    code, _, err = run(["identify-bench", str(paths[0]), "--structure", "lure", "--nonlinearity", "saturation",
                        "--validate", str(paths[1])])
    assert code == 2 and "lure structure takes" in err


# ---- the core's recursion against a Python reference ------------------------------------------------------------

def _lure_reference(b, a, level, u, per_output=0.0, sign=1.0):
    """The Lur'e recursion of include/tendyn/lure.hpp written out in plain Python floats (what
    block_simulation._lure_simulate ran before the core took it over), in the same arithmetic order."""
    n = len(a)
    b, a = [float(v) for v in b], [float(v) for v in a]
    b1, F = b[0], max(float(level), 0.0)
    thr, sb, ab1 = abs(b1) * F, (1.0 if b1 >= 0.0 else -1.0), abs(b1)
    inv_g0 = (1.0 + sum(a)) / sum(b) if sum(b) != 0.0 else 0.0
    out, yh, wh = [0.0] * len(u), [0.0] * n, [0.0] * (n - 1)
    for t in range(len(u) - 1):
        ut = float(u[t])
        acc = b1 * ut
        for k in range(n - 1):
            acc += b[k + 1] * wh[k]
        for k in range(n):
            acc -= a[k] * yh[k]
        yt = yh[0]
        if per_output != 0.0:
            F = max(float(level) + per_output * (sign * yt if sign != 0.0 else abs(yt)), 0.0)
            thr = ab1 * F
        d = acc - yt
        if -thr <= d <= thr:
            yh, wh, out[t + 1] = [yt] * n, [yt * inv_g0] * (n - 1), yt
            continue
        f, ynew = (F * sb, acc - thr) if d > 0.0 else (-F * sb, acc + thr)
        yh = [ynew] + yh[:-1]
        wh = ([ut - f] + wh[:-1]) if n > 1 else wh
        out[t + 1] = ynew
    return np.array(out)


@pytest.mark.parametrize("n, mu, sign", [(1, 0.0, 1.0), (2, 0.0, 1.0), (3, 0.0, 1.0), (2, 0.3, 1.0), (3, 0.3, -1.0),
                                         (2, 0.3, 0.0), (2, -0.2, 1.0)])
def test_core_lure_recursion_equals_the_python_reference_bit_for_bit(n, mu, sign):
    """block_simulation._lure_simulate (the core's lure.hpp) gives the reference's output bit for bit on a stable
    G of order 1–3 (a negative b_1 included), with the level constant or linear in the output (both signs and
    |y|), over an input that both sticks and slips (each on 5–95 % of the samples)."""
    from tendyn.ident.block_simulation import _lure_simulate

    rng = np.random.default_rng(10 * n + int(10 * mu) + int(sign))
    a = np.real(np.poly(rng.uniform(0.2, 0.9, n)))[1:]
    b = rng.uniform(0.05, 0.3, n) * (-1.0 if n == 2 and sign == 0.0 else 1.0)
    u = np.repeat(rng.normal(0.0, 1.0, 60), 25) + 0.05 * rng.normal(size=1500)
    y = _lure_simulate(b, a, 0.4, u, mu, sign)
    ref = _lure_reference(b, a, 0.4, u, mu, sign)
    assert y.dtype == np.float64 and y.shape == u.shape
    assert np.array_equal(y, ref)
    stuck = np.mean(np.diff(ref) == 0.0)
    assert 0.05 < stuck < 0.95, stuck
    assert _lure_simulate(b, a, 0.4, u[:1]).tolist() == [0.0] and _lure_simulate(b, a, 0.4, u[:0]).size == 0
