"""McGill 2N tendon bench twin (S1): analytic plant (C13, C14), simulator invariants, C22, device file."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from tendyn import _core
from tendyn.analysis import tendon_drive as td
from tendyn.claims import assert_claim
from tendyn.device import load_device
from tendyn.device.schema import DeviceError
from tendyn.device.tendon_bench import TendonBench, load_tendon_bench
from tendyn.devices import bundled
from tendyn.sim import tendon_bench as tb

RATE = 20000.0


@pytest.fixture(scope="module")
def bench() -> TendonBench:
    return load_tendon_bench(bundled("mcgill_bench"))


def frictionless(b: TendonBench, **kw) -> TendonBench:
    return b.replace(friction_c0=0.0, friction_mu_tension=0.0, **kw)


# ---------------------------------------------------------------------------------------------------------
# Analytic plant (C13, C14)
# ---------------------------------------------------------------------------------------------------------

def test_k_e_c13(claims_ctx):
    assert_claim("C13", claims_ctx)


def test_derived_plant_matches_printed_eq2_c14(claims_ctx):
    assert_claim("C14", claims_ctx)
    p = td.derive_plant()
    s, r, I_M, B, ke, I_c, kz = p.s, p.r, p.I_M, p.B, p.k_e, p.I_c, p.k_z
    # D − N = r² s (I_M s + B)(I_c s² + k_e + k_z)
    assert sp.expand(p.den - p.num - r**2 * s * (I_M * s + B) * (I_c * s**2 + ke + kz)) == 0
    # stiff-load limit k_z → ∞: k_e / (r² I_M s² + r² B s + k_e)
    lim = sp.limit(p.num / p.den, kz, sp.oo)
    assert sp.simplify(lim - ke / (r**2 * I_M * s**2 + r**2 * B * s + ke)) == 0


def test_plant_tf_numeric(bench):
    num, den = td.plant_tf(bench)
    assert len(den) == 5 and len(num) == 3
    assert den[0] == pytest.approx(bench.mass_motor * bench.mass_load)
    assert num[-1] / den[-1] == pytest.approx(1.0)  # G(0) = 1
    # stiff limit: resonance at 30 Hz (DEVICES.md landmark), and 1e9 is close to the limit
    ns, ds = td.plant_tf(bench.replace(k_z=math.inf))
    assert math.sqrt(ds[-1] / ds[0]) / (2 * math.pi) == pytest.approx(30.0, abs=0.1)
    w = 2 * math.pi * np.array([1.0, 10.0, 30.0, 100.0])
    np.testing.assert_allclose(td.frequency_response(bench, w), np.polyval(ns, 1j * w) / np.polyval(ds, 1j * w),
                               rtol=2e-3)
    # k1 sweep landmarks of DEVICES.md (stiff load): 6.6 Hz, 30 Hz, 65.7 Hz
    for k1, f_expected in ((1e3, 6.6), (4.56e6, 65.7)):
        _, d = td.plant_tf(bench.replace(k1=k1, k_z=math.inf))
        assert math.sqrt(d[-1] / d[0]) / (2 * math.pi) == pytest.approx(f_expected, abs=0.1)


# ---------------------------------------------------------------------------------------------------------
# Simulated FRF = analytic G(jω) (C14, friction off)
# ---------------------------------------------------------------------------------------------------------

def test_frf_matches_analytic_stiff_load(bench):
    b = frictionless(bench)
    f = np.array([2.0, 4.0, 8.0, 15.0, 22.0, 27.0, 30.0, 33.0, 40.0, 55.0, 75.0, 100.0])
    res = tb.stepped_sine(b, omega=2 * math.pi * f, amplitude_N=0.5, cycles=10, settle_s=1.0, rate_hz=RATE)
    g = td.frequency_response(b, 2 * math.pi * f)
    mag_err = np.abs(np.abs(res.ratio) / np.abs(g) - 1.0)
    ph_err = np.abs(np.degrees(np.angle(res.ratio / g)))
    print("\nC14 stiff load: max |mag| rel error %.2e, max phase error %.3f deg" % (mag_err.max(), ph_err.max()))
    assert mag_err.max() < 0.01
    assert ph_err.max() < 3.0


def test_frf_matches_analytic_soft_load(bench):
    b = frictionless(bench, k_z=1.0e3)
    # away from the undamped anti-resonance sqrt(k_z/I_c) = 22.5 Hz, where |G| → 0 and relative error is
    # meaningless; the 108 Hz load mode has ζ ≈ 0.001, hence the long settling.
    f = np.array([2.0, 4.0, 6.0, 10.0, 40.0, 60.0])
    res = tb.stepped_sine(b, omega=2 * math.pi * f, amplitude_N=0.5, cycles=10, settle_s=8.0, rate_hz=RATE)
    g = td.frequency_response(b, 2 * math.pi * f)
    mag_err = np.abs(np.abs(res.ratio) / np.abs(g) - 1.0)
    ph_err = np.abs(np.degrees(np.angle(res.ratio / g)))
    print("\nC14 soft load: max |mag| rel error %.2e, max phase error %.3f deg" % (mag_err.max(), ph_err.max()))
    assert mag_err.max() < 0.01
    assert ph_err.max() < 3.0


# ---------------------------------------------------------------------------------------------------------
# C22: the open-loop resonance moves with amplitude (friction on, very stiff load)
# ---------------------------------------------------------------------------------------------------------

def test_resonance_peak_moves_with_amplitude_c22(bench):
    assert bench.k_z >= 1e9 and bench.friction_c0 > 0
    amplitudes = [0.31, 0.34, 0.38, 0.6]
    peaks = []
    print("\nC22 open-loop peak of |F_m/F_tau| vs amplitude (k_z = %.0e N/m, F_c at rest %.3f N):"
          % (bench.k_z, bench.friction_at_rest))
    print("  amplitude [N]   peak [Hz]   |G| at peak")
    for a in amplitudes:
        pk = tb.resonance_peak(bench, a, f_lo=8.0, f_hi=40.0, step_hz=1.0, refine_hz=0.25, rate_hz=RATE)
        peaks.append(pk.peak_hz)
        print("  %13.2f   %9.2f   %11.3f" % (a, pk.peak_hz, pk.peak_magnitude))
    peaks = np.array(peaks)
    assert np.all((peaks >= 12.0) & (peaks <= 35.0)), peaks
    assert peaks.max() - peaks.min() >= 12.0, peaks
    assert np.all(np.diff(peaks) > 0), peaks
    # friction off: the peak is the linear one, ω_n sqrt(1 − 2ζ²) ≈ 29.9 Hz, at any amplitude
    lin = tb.resonance_peak(frictionless(bench), 0.31, f_lo=8.0, f_hi=40.0, rate_hz=RATE)
    assert lin.peak_hz == pytest.approx(30.0 * math.sqrt(1 - 2 * 0.05**2), abs=0.3)


# ---------------------------------------------------------------------------------------------------------
# Simulator invariants
# ---------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("k_z", [1.0e9, 1.0e3])
def test_stiction_below_friction_no_motion(bench, k_z):
    b = bench.replace(k_z=k_z)
    fc = b.friction_at_rest  # node friction at rest: F_c0 + μ_T T_pre
    n = int(2.0 * RATE)
    for sign in (1.0, -1.0):
        run = tb.simulate(b, np.full(n, sign * 0.95 * fc), rate_hz=RATE)
        # nothing moves, bit for bit
        assert np.all(run.x_a == 0.0) and np.all(run.x_b == 0.0) and np.all(run.x_load == 0.0)
        assert np.all(run.force == run.force[0]) and np.all(run.tension_a == b.pretension)
        # above the friction level the driven node slides
        run = tb.simulate(b, np.full(n, sign * 1.2 * fc), rate_hz=RATE)
        moved = run.x_a if sign > 0 else run.x_b
        assert np.max(np.abs(moved)) > 1e-7
        assert np.sign(moved[-1]) == sign


def test_stuck_node_state_in_data(bench):
    model = tb.bench_model(bench, RATE)
    data = _core.TendonBenchData(model, 0)
    for _ in range(100):
        _core.step(model, data, 0.5 * bench.friction_at_rest)
    assert data.stuck_a and data.stuck_b and data.x_a == 0.0
    assert data.friction_a == pytest.approx(0.5 * bench.friction_at_rest)
    with pytest.raises(ValueError, match="NaN or Inf"):
        _core.step(model, data, float("nan"))


def test_noise_deterministic(bench):
    b = bench.replace(noise_force=0.05, noise_position=2e-6)
    u = 0.5 * np.sin(2 * math.pi * 20.0 * np.arange(20000) / RATE)
    r1 = tb.simulate(b, u, seed=7)
    r2 = tb.simulate(b, u, seed=7)
    r3 = tb.simulate(b, u, seed=8)
    for name in ("force", "position", "x_a", "x_b", "tension_a"):
        assert np.array_equal(getattr(r1, name), getattr(r2, name)), name
    assert not np.array_equal(r1.force, r3.force)
    assert not np.array_equal(r1.position, r3.position)
    assert np.array_equal(r1.x_a, r3.x_a)  # the noise is on the sensor only
    # noise level as configured (difference from the noiseless run)
    r0 = tb.simulate(bench, u, seed=7)
    assert np.std(r1.force - r0.force) == pytest.approx(0.05, rel=0.05)
    assert np.std(r1.position - r0.position) == pytest.approx(2e-6, rel=0.05)


def test_tension_only(bench):
    # Large negative command near resonance on a moderately soft load: motor B (negative half-waves)
    # drives the load, the rebound unloads tendon A until it goes slack; it never pushes.
    b = bench.replace(k_z=1.0e4)
    n = int(1.0 * RATE)
    t = (np.arange(n) + 0.5) / RATE
    u = -40.0 * np.abs(np.sin(2 * math.pi * 15.0 * t))
    run = tb.simulate(b, u, rate_hz=RATE)
    assert np.all(run.tension_a >= 0.0) and np.all(run.tension_b >= 0.0)
    assert np.any(run.tension_a == 0.0), run.tension_a.min()
    assert run.tension_b.max() > 2 * b.pretension
    # the tension law from the positions, by hand: T = max(0, T_pre + (k_e/2)·stretch), stretch x_a − x_load
    # for A and x_load − x_b for B (a slack tendon carries nothing, it never pushes)
    k_t = 0.5 * b.k1 * b.k2 / (b.k1 + b.k2)
    np.testing.assert_allclose(run.tension_a, np.maximum(0.0, b.pretension + k_t * (run.x_a - run.x_load)),
                               rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(run.tension_b, np.maximum(0.0, b.pretension + k_t * (run.x_load - run.x_b)),
                               rtol=1e-12, atol=1e-9)


def test_small_signal_common_mode_decoupled(bench):
    # friction off, both tendons taut: the sum of the tensions responds only to |u| (common mode) and
    # F_m equals the differential mode k_e (x1 − x_load), x1 = (x_a + x_b)/2
    b = frictionless(bench, k_z=1e3)
    u = 0.5 * np.sin(2 * math.pi * 12.0 * (np.arange(8000) + 0.5) / RATE)
    run = tb.simulate(b, u)
    x1 = 0.5 * (run.x_a + run.x_b)
    np.testing.assert_allclose(run.force, b.k_e * (x1 - run.x_load), atol=1e-9)
    assert run.tension_a.min() > 0 and run.tension_b.min() > 0


def test_amplifier_lag_first_order(bench):
    b = frictionless(bench)
    fc_hz = 1000.0
    f = np.array([10.0, 100.0, 300.0])
    r0 = tb.stepped_sine(b, omega=2 * math.pi * f, amplitude_N=0.5, rate_hz=RATE)
    r1 = tb.stepped_sine(b.replace(amplifier_lag=1.0 / (2 * math.pi * fc_hz)), omega=2 * math.pi * f, amplitude_N=0.5,
                         rate_hz=RATE)
    lag = 1.0 / (1.0 + 1j * f / fc_hz)
    np.testing.assert_allclose(np.abs(r1.ratio / r0.ratio), np.abs(lag), rtol=2e-3)
    np.testing.assert_allclose(np.degrees(np.angle(r1.ratio / r0.ratio)), np.degrees(np.angle(lag)), atol=0.2)


def test_swept_sine_friction_off(bench):
    b = frictionless(bench)
    sw = tb.swept_sine(b, 2.0, 100.0, duration_s=20.0, amplitude_N=1.0, rate_hz=RATE)
    sel = (sw.freq_hz > 5.0) & (sw.freq_hz < 80.0)
    g = td.frequency_response(b, 2 * math.pi * sw.freq_hz[sel])
    err = np.abs(sw.ratio[sel] / g - 1.0)
    assert np.median(err) < 0.02 and err.max() < 0.05


def test_invalid_model_raises(bench):
    with pytest.raises(ValueError):
        tb.simulate(bench.replace(mass_motor=-1.0), np.zeros(10))
    with pytest.raises(ValueError):
        tb.simulate(bench, np.array([0.0, np.inf]))


def test_low_speed_loop_dead_band_c24(bench):
    """C21/C24: the 0.2 Hz, 0.31 N loop on the stiff load, against the quasi-static dead-band by hand.

    Class-B split, Coulomb friction F_c = F_c0 + μ T at each node (F_c,rest = F_c0 + μ T_pre), stiff load.
    A node that slid forward on its half-wave and is then released (u⁺ = 0) slides back until its extra
    tension D' balances friction: D' = F_c0 + μ (T_pre + D') ⇒ D' = F_c,rest/(1 − μ). On its next half-wave
    it slides forward with extra tension D = u − F_c0 − μ(T_pre + D) ⇒ D = (u − F_c,rest)/(1 + μ), up to the
    peak u = A. Meanwhile the other node rests at D'. So the steady loop swings F_m between ±(D − D'):
      F_peak = (A − F_c,rest)/(1 + μ) − F_c,rest/(1 − μ)
    The forward slide is quasi-static to ~1e-5 (damping: the node creeps at < 1e-4 m/s), so the extra tension
    of the driven tendon peaks at D within 2e-4 (with friction from the other tendon it would be μ D' higher,
    1.6e-3). The release is not: when u⁺ reaches 0 the drive stops abruptly and the sliding node overshoots
    by up to v √(k m) ≈ 7e-5 m/s · √(1.02e4 N/m · 0.29 kg) ≈ 4e-3 N, hence the looser bound on the loop.
    A frictionless channel returns the whole 0.31 N (G(0) = 1)."""
    loop = tb.low_speed_loop(bench, freq_hz=0.2, amplitude_N=0.31, cycles=1)
    assert loop.u.shape == loop.force.shape and loop.u.size > 100
    assert set(loop.to_dict()) >= {"u", "force", "time"}
    fc, mu, A = bench.friction_c0 + bench.friction_mu_tension * bench.pretension, bench.friction_mu_tension, 0.31
    D, D_rel = (A - fc) / (1 + mu), fc / (1 - mu)
    assert loop.force.max() == pytest.approx(D - D_rel, abs=4e-3)
    assert loop.force.min() == pytest.approx(-(D - D_rel), abs=4e-3)
    n = int(round(2 / 0.2 * RATE))
    run = tb.simulate(bench, A * np.sin(2 * math.pi * 0.2 * (np.arange(n) + 0.5) / RATE), rate_hz=RATE)
    assert run.tension_a.max() - bench.pretension == pytest.approx(D, rel=2e-4)
    assert run.tension_b.max() - bench.pretension == pytest.approx(D, rel=2e-4)
    free = tb.low_speed_loop(frictionless(bench), freq_hz=0.2, amplitude_N=0.31, cycles=1)
    assert free.force.max() == pytest.approx(0.31, rel=1e-3)


def _settle_then_hold(b, u_settle, f_net, node, steps_hold=4000):
    """Drive one node with u_settle until it sticks, then command the u that leaves a net applied force
    f_net on that node (F_pre + |u| − T_own, along the node's pull); return (stuck throughout, own and
    other tension at the hold, position change of the node)."""
    model = tb.bench_model(b, RATE)
    data = _core.TendonBenchData(model, 0)
    for _ in range(int(1.5 * RATE)):
        _core.step(model, data, u_settle)
    own = data.tension_a if node == "a" else data.tension_b
    other = data.tension_b if node == "a" else data.tension_a
    x0 = data.x_a if node == "a" else data.x_b
    assert (data.stuck_a if node == "a" else data.stuck_b)
    mag = own - b.pretension + f_net                       # |u| that pulls with F_pre + |u| = T_own + f_net
    u_hold = mag if node == "a" else -mag
    stuck = True
    for _ in range(steps_hold):
        _core.step(model, data, u_hold)
        stuck &= bool(data.stuck_a if node == "a" else data.stuck_b)
    x1 = data.x_a if node == "a" else data.x_b
    return stuck, own, other, x1 - x0


@pytest.mark.parametrize("node", ["a", "b"])
def test_friction_grows_with_the_nodes_own_tendon(bench, node):
    """DEVICES.md §2: F_c = F_c0 + μ_T T with T the tension of THAT node's tendon. After pulling one node to
    T_own ≈ 25 N (the other tendon stays at T_pre = 5 N), a net force of ±0.97 (F_c0 + μ T_own) on it must
    leave it stuck, bit for bit; 1.03 (F_c0 + μ T_own) must break it away. With friction from the other
    tendon (F_c0 + μ T_pre = 0.45 N) or from the pretension, 0.97·1.45 N would already slide."""
    b = bench.replace(friction_c0=0.2, friction_mu_tension=0.05, k_z=1e9)
    u = 20.0 if node == "a" else -20.0
    probe = _settle_then_hold(b, u, 0.0, node, steps_hold=1)
    own, other = probe[1], probe[2]
    fc_own = 0.2 + 0.05 * own
    assert own > 20.0 and other == pytest.approx(b.pretension, abs=1e-12)
    assert fc_own > 2 * (0.2 + 0.05 * other)
    for f in (0.97 * fc_own, -0.97 * fc_own):
        stuck, _, _, dx = _settle_then_hold(b, u, f, node)
        assert stuck and dx == 0.0, (node, f, dx)
    stuck, _, _, dx = _settle_then_hold(b, u, -1.03 * fc_own, node)
    assert not stuck and dx != 0.0


@pytest.mark.parametrize("u", [3.0, -3.0])
def test_sensed_displacement_static_value(bench, u):
    """X_t at a static equilibrium, by hand (friction off, clamped load x_load = 0, constant command u).
    The driven tendon stretches by |u|/(k_e/2), the other not at all; each sensing point sits at
    s = (k1 x_motor + k2 x_load)/(k1 + k2); X_t = (s_a + s_b)/2 = (k1/(k1 + k2)) u/k_e = u/k2
    (the k2 section of the channel carries u): 3 N / 1e5 N/m = 30 µm. (k1 and k2 exchanged: u/k1 = 117 µm.)"""
    b = frictionless(bench, k_z=1e9)
    run = tb.simulate(b, np.full(int(3.0 * RATE), u), rate_hz=RATE)
    assert run.position[-1] == pytest.approx(u / b.k2, rel=1e-6)
    assert run.force[-1] == pytest.approx(u, rel=1e-6)


# ---------------------------------------------------------------------------------------------------------
# Device file
# ---------------------------------------------------------------------------------------------------------

def test_bundled_file_loads(bench):
    assert isinstance(bench, TendonBench)
    assert bench.ratio == 15.0 and bench.k1 == 2.566e4 and bench.mass_motor == 0.575
    assert 0.1 <= bench.friction_c0 <= 0.25
    dev = load_device(bundled("mcgill_bench"))
    assert isinstance(dev, TendonBench) and dev == bench
    text = bundled("mcgill_bench").read_text()
    for key in ("k1", "k2", "mass_motor", "damping_motor", "mass_load", "k_z", "pretension", "friction_c0",
                "friction_mu_tension", "amplifier_lag", "noise_force", "noise_position", "ratio"):
        line = next(ln for ln in text.splitlines() if ln.startswith(key + " "))
        assert any(lab in line for lab in ("[SEED", "[INFERRED", "[ASSUMPTION")), line


def _variant(tmp_path, old: str, new: str, name: str = "bad_bench.toml"):
    text = bundled("mcgill_bench").read_text()
    assert old in text, old
    p = tmp_path / name
    p.write_text(text.replace(old, new, 1))
    return p


@pytest.mark.parametrize(
    "old, new, fragments",
    [
        ("k2 = 1.0e5", "k2 = 1.0e5\nk3 = 2.0", ["bench.k3", "unknown field"]),
        ("mass_load = 0.05 ", "masss_load = 0.05 ", ["bench.masss_load", "did you mean 'mass_load'"]),
        ("k1 = 2.566e4", "# k1 removed", ["bench.k1", "missing required field"]),
        ("k2 = 1.0e5", 'k2 = "stiff"', ["bench.k2", "must be a number", "string 'stiff'"]),
        ("mass_motor = 0.575", "mass_motor = -0.575", ["bench.mass_motor", "must be > 0"]),
        ("damping_motor = 10.8", "damping_motor = nan", ["bench.damping_motor", "must be finite"]),
        ("k_z = 1.0e9", "k_z = inf", ["bench.k_z", "must be finite"]),
        ("pretension = 5.0", "pretension = true", ["bench.pretension", "must be a number", "boolean"]),
        ("amplifier_lag = 0.0", "amplifier_lag = 0.01", ["bench.amplifier_lag", "1000 Hz"]),
        ('kind = "tendon_bench_2n"', 'kind = "tendon_bench_2n"\ncolour = "red"', ["device.colour", "unknown field"]),
        ("[bench]", "[extra]\na = 1\n[bench]", ["extra", "unknown field"]),
        ("friction_mu_tension = 0.005", "friction_mu_tension = 0.005 0.1", ["TOML syntax error"]),
        ("noise_position = 0.0 ", "peak_force = 0.0\nnoise_position = 0.0 ", ["bench.peak_force", "must be > 0"]),
        ("noise_position = 0.0 ", "peak_force = nan\nnoise_position = 0.0 ", ["bench.peak_force", "finite"]),
        ("noise_position = 0.0 ", 'peak_force = "50 N"\nnoise_position = 0.0 ', ["bench.peak_force", "number"]),
    ],
)
def test_malformed_bench_files(tmp_path, old, new, fragments):
    p = _variant(tmp_path, old, new)
    with pytest.raises(DeviceError) as exc:
        load_tendon_bench(p)
    msg = str(exc.value)
    assert msg.startswith("bad_bench.toml"), msg
    for frag in fragments:
        assert frag in msg, msg


def test_peak_force_is_optional_and_read(tmp_path, bench):
    """[bench].peak_force (the actuators' limit [N]) may be left out — the bundled McGill file does (S1 gives no
    limit) and reads None — and is read when given; it is no parameter of the simulated plant."""
    assert bench.peak_force is None and "peak_force" not in bundled("mcgill_bench").read_text()
    b = load_tendon_bench(_variant(tmp_path, "noise_position = 0.0 ", "peak_force = 42.5\nnoise_position = 0.0 "))
    assert b.peak_force == 42.5 and b.replace(peak_force=None) == bench.replace(source=b.source)
    assert not hasattr(tb.bench_model(b), "peak_force")


@pytest.mark.parametrize("seed", [0, 7, 21])
def test_generated_bench_peak_force_from_its_motor(tmp_path, seed):
    """A generated bench's limit from the motor it states (6 significant digits in its description):
    peak_force = τ_pk/ρ − T_pre (motor A pulls F_pre + max(u, 0)) and mass_motor = 2 J/ρ²; without the field: None."""
    import re

    from tendyn.devices.generate import write_tendon_bench

    b = load_device(write_tendon_bench(tmp_path, seed=seed))
    J, rho, tau = (float(x) for x in re.search(r"J = (\S+) kg m2, rho = (\S+) m, peak torque (\S+) N m",
                                                 b.description).groups())
    assert b.peak_force == pytest.approx(tau / rho - b.pretension, rel=1e-4)
    assert b.mass_motor == pytest.approx(2 * J / rho**2, rel=1e-4)
    assert load_device(write_tendon_bench(tmp_path, seed=seed, name="nolimit", peak_force=False)).peak_force is None
    run = tb.simulate(b, np.full(200, 0.5 * b.peak_force), rate_hz=RATE)   # the twin runs a generated bench
    assert np.all(np.isfinite(run.force))


def test_wrong_kind_and_missing_file(tmp_path):
    p = _variant(tmp_path, 'kind = "tendon_bench_2n"', 'kind = "arm"')
    with pytest.raises(DeviceError, match=r"device\.kind: must be 'tendon_bench_2n'"):
        load_tendon_bench(p)
    with pytest.raises(DeviceError, match="file not found"):
        load_tendon_bench(tmp_path / "nope.toml")


@pytest.mark.parametrize("kwargs, message", [
    (dict(omega=[0.0]), "omega must be"),
    (dict(omega=[2 * math.pi * 6000.0]), "omega must be"),    # above rate_hz/4 at 20 kHz
    (dict(omega=[10.0], amplitude_N=0.0), "amplitude_N must be"),
    (dict(omega=[10.0], cycles=0), "cycles must be"),
])
def test_stepped_sines_reject_bad_plans(bench, kwargs, message):
    """The open-loop stepped sine and the loop stepped sine share one plan check (frequency band, amplitude,
    cycle counts)."""
    args = dict(amplitude_N=0.3) | kwargs
    with pytest.raises(ValueError, match=message):
        tb.stepped_sine(bench, **args)
    with pytest.raises(ValueError, match=message):
        tb.loop_stepped_sine(bench, None, **args)
