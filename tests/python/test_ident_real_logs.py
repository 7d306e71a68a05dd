"""Identification on logs as real benches write them (issue 18): stale rows, logged velocities, units, the
velocity threshold in one place and honoured by --stream, implausible values said.

The logs are generated here from a device generated here (a 2-joint cable arm, not a bundled twin): joint
torques by Pinocchio's RNEA plus viscous and Coulomb friction chosen by the test. The estimator reads only
the log; the test compares its parameters with the truth it built.
"""

from __future__ import annotations

import numpy as np
import pytest

from tendyn.device import load_device
from tendyn.devices.generate import write_cable_device
from tendyn.ident import IDIM, IdentModel
from tendyn.ident.treatment import drop_stale
from tendyn.io import make_log

FV = np.array([0.35, 0.2])      # N·m·s/rad, the test's truth
FS = np.array([0.12, 0.08])     # N·m


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    path = write_cable_device(tmp_path_factory.mktemp("dev"), 2, seed=3)
    m = IdentModel(load_device(path))
    m.file = path
    return m


def _motion(t, n, seed):
    rng = np.random.default_rng(seed)
    q = np.zeros((t.size, n)); qd = np.zeros_like(q); qdd = np.zeros_like(q)
    for j in range(n):
        for k in range(1, 4):
            a, f, ph = rng.uniform(0.2, 0.5) / k, 0.3 * k * (1 + 0.4 * j), rng.uniform(0, 2 * np.pi)
            w = 2 * np.pi * f
            q[:, j] += a * np.sin(w * t + ph); qd[:, j] += a * w * np.cos(w * t + ph)
            qdd[:, j] -= a * w * w * np.sin(w * t + ph)
    return q, qd, qdd


def true_torques(m, t, seed, fv=FV):
    """The truth's joint torques [N·m] of the motion of ``seed`` at times t: RNEA + the test's friction."""
    import pinocchio as pin

    q, qd, qdd = _motion(t, m.n_active, seed)
    model = m.compiled.pinocchio_model
    data = model.createData()
    tau = np.array([pin.rnea(model, data, q[s], qd[s], qdd[s]) for s in range(t.size)])
    return q, qd, tau + fv * qd + FS * np.tanh(qd / 1e-3)


def synthetic_log(m, rate_hz=1000.0, duration=12.0, seed=0, velocities=False, noise=0.0, counts=None, fv=FV,
                  jitter=0.0):
    """A log of the arm following sums of sines; ``counts``: encoder counts per motor turn (quantised q);
    ``fv``: the viscous coefficients [N·m·s/rad] of the truth; ``jitter``: time stamps off the uniform grid
    by up to this fraction of a sample (the signals sampled at the true stamps)."""
    t = np.arange(int(duration * rate_hz)) / rate_hz
    t = t + jitter / rate_hz * np.random.default_rng(seed + 200).uniform(-1, 1, t.size)
    q, qd, tau = true_torques(m, t, seed, fv)
    qm = (q - m.joint_offsets) @ m.G.T
    if counts:
        qm = np.round(qm * counts / (2 * np.pi)) * 2 * np.pi / counts
    y = np.linalg.solve(m.G.T, tau.T).T + noise * np.random.default_rng(seed + 100).normal(size=tau.shape)
    cols = {"time": t}
    cols.update({f"q_motor_{i + 1}": qm[:, i] for i in range(m.n_motors)})
    if velocities:
        qdm = qd @ m.G.T
        cols.update({f"qd_motor_{i + 1}": qdm[:, i] for i in range(m.n_motors)})
    cols.update({f"torque_motor_{i + 1}": y[:, i] for i in range(m.n_motors)})
    linear = [i + 1 for i, j in enumerate(m.motor_joints) if j in m.prismatic_numbers]
    units = {f"{c}_{i}": u for i in linear for c, u in (("q_motor", "m"), ("qd_motor", "m/s"),
                                                        ("torque_motor", "N")) if f"{c}_{i}" in cols}
    return make_log(cols, device=m.device.name, rate_hz=rate_hz, seed=seed, experiment="exciting",
                    units=units or None)


def true_base(m) -> np.ndarray:
    """The truth as base parameters: the device file's links (the RNEA's), no rotor, the test's friction."""
    x = m.prior()
    names = m.standard_names
    for k, n in enumerate(names):
        stem, num = n.rstrip("0123456789"), n[len(n.rstrip("0123456789")):]
        if stem in ("IA", "IAm", "FVm", "FSm", "OFFSET"):
            x[k] = 0.0
        elif stem == "FV":
            x[k] = FV[m.active_numbers.index(int(num))]
        elif stem == "FS":
            x[k] = FS[m.active_numbers.index(int(num))]
    return m.base.combination @ x


def torque_error(m, est, clean) -> float:
    """‖W (x̂ − x)‖ / ‖W x‖ on the treated clean log: how far the identified model's torques are from the truth's."""
    _, W, _, _, _ = IDIM(m.device, cutoff_hz=est.cutoff_hz, decimate=est.decimate,
                         velocity_threshold=0.0).observations(clean)
    Wb = W[:, list(m.base.columns)]
    xt = true_base(m)
    return float(np.linalg.norm(Wb @ (est.params_ - xt)) / np.linalg.norm(Wb @ xt))


def with_stale_rows(log, fraction, seed):
    """The log with ``fraction`` of its rows replaced by a repeat of the previous row (all but time): a logger
    writing samples the sensors had not refreshed."""
    rng = np.random.default_rng(seed)
    n = log.n_samples
    stale = np.zeros(n, bool)
    stale[1 + rng.choice(n - 1, int(fraction * n), replace=False)] = True
    cols = {}
    for name, x in log.columns.items():
        x = x.copy()
        if name != "time":
            for k in np.flatnonzero(stale):       # sample-and-hold: a run of stale rows holds the first value
                x[k] = x[k - 1]
        cols[name] = x
    return make_log(cols, device=log.meta["device"], rate_hz=log.meta["rate_hz"], seed=log.meta["seed"],
                    experiment="exciting"), int(stale.sum())


# -- 1a. stale rows ----------------------------------------------------------------------------------------

def test_drop_stale_differentiates_on_the_true_time_stamps():
    """A sine logged with 15 % stale rows: after drop_stale its central differences match the true derivative
    as on a clean log; taken on the stale rows they are off by the full signal speed."""
    rate = 200.0
    t = np.arange(2000) / rate
    x = np.sin(2 * np.pi * 0.7 * t)[:, None]
    tau = np.cos(2 * np.pi * 0.3 * t)[:, None]
    rng = np.random.default_rng(1)
    xs, taus = x.copy(), tau.copy()
    idx = np.sort(1 + rng.choice(t.size - 2, 300, replace=False))
    for k in idx:
        xs[k], taus[k] = xs[k - 1], taus[k - 1]
    tt, xq, tq, _, n, retimed = drop_stale(t, rate, xs, taus)
    assert n == np.count_nonzero(np.all(xs[1:] == xs[:-1], axis=1) & np.all(taus[1:] == taus[:-1], axis=1))
    assert retimed and tt.size == t.size
    truth = 2 * np.pi * 0.7 * np.cos(2 * np.pi * 0.7 * tt)
    err_dropped = np.max(np.abs(np.gradient(xq[:, 0], 1 / rate) - truth)[1:-1])
    err_raw = np.max(np.abs(np.gradient(xs[:, 0], 1 / rate) - 2 * np.pi * 0.7 * np.cos(2 * np.pi * 0.7 * t))[1:-1])
    assert err_dropped < 0.05 * 2 * np.pi * 0.7 < err_raw
    # a clean uniform log passes through untouched
    tt, xq, tq, _, n, retimed = drop_stale(t, rate, x, tau)
    assert n == 0 and not retimed and xq is x
    # time stamps jittered by ±0.4 sample (no stale row): re-timed, the derivative on the grid is right again
    tj = t + 0.4 / rate * rng.uniform(-1, 1, t.size)
    xj = np.sin(2 * np.pi * 0.7 * tj)[:, None]
    tt, xq, _, _, n, retimed = drop_stale(tj, rate, xj, np.cos(tj)[:, None])
    assert n == 0 and retimed and tt.size == t.size and np.allclose(np.diff(tt), 1 / rate)
    err_retimed = np.max(np.abs(np.gradient(xq[:, 0], 1 / rate) - 2 * np.pi * 0.7 * np.cos(2 * np.pi * 0.7 * tt))[2:-2])
    err_jitter = np.max(np.abs(np.gradient(xj[:, 0], 1 / rate) - truth)[1:-1])
    assert err_retimed < 0.01 * 2 * np.pi * 0.7 < err_jitter


def test_stale_rows_are_dropped_and_counted(arm):
    clean = synthetic_log(arm, rate_hz=200.0, duration=30.0, seed=2)
    stale, n_stale = with_stale_rows(clean, 0.15, seed=5)
    kw = dict(cutoff_hz=10.0, decimate=2, velocity_threshold=0.0)
    e_clean = torque_error(arm, IDIM(arm.device, **kw).fit(clean, crossval=False), clean)
    est = IDIM(arm.device, **kw).fit(stale, crossval=False)
    assert est.treatment_.stale_dropped == n_stale > 0.1 * clean.n_samples
    assert est.treatment_.retimed
    assert f"{n_stale} stale samples dropped" in est.result_.table()
    assert est.result_.to_dict()["treatment"]["stale_dropped"] == n_stale
    e_stale = torque_error(arm, est, clean)
    assert e_clean < 0.01
    assert e_stale < 0.02, f"stale rows dropped: torque error {e_stale:.4f} (clean log: {e_clean:.4f})"


# -- 1b. logged velocities ---------------------------------------------------------------------------------

def test_logged_velocities_are_used_and_said(arm):
    """Coarse encoder (256 counts per motor turn): differentiated positions are noisy, the logged velocities
    are not; the fit with them is closer to the truth, and the treatment says which were used."""
    log = synthetic_log(arm, rate_hz=1000.0, duration=12.0, seed=4, velocities=True, counts=256)
    clean = synthetic_log(arm, rate_hz=1000.0, duration=12.0, seed=4)
    kw = dict(cutoff_hz=20.0, decimate=10, velocity_threshold=0.0)
    auto = IDIM(arm.device, **kw).fit(log, crossval=False)
    diff = IDIM(arm.device, velocities="differentiate", **kw).fit(log, crossval=False)
    assert auto.treatment_.velocities == "logged" and diff.treatment_.velocities == "differentiate"
    assert "logged velocities" in auto.result_.table()
    assert auto.result_.to_dict()["treatment"]["velocities"] == "logged"
    e_logged, e_diff = torque_error(arm, auto, clean), torque_error(arm, diff, clean)
    assert e_logged < 0.5 * e_diff, f"logged {e_logged:.4f} vs differentiated {e_diff:.4f}"


def test_logged_velocities_asked_for_but_absent(arm):
    from tendyn.io import LogError

    log = synthetic_log(arm, duration=2.0)
    with pytest.raises(LogError, match="qd_motor_"):
        IDIM(arm.device, velocities="logged").fit(log, crossval=False)
    assert IDIM(arm.device).fit(log, crossval=False).treatment_.velocities == "differentiate"



def test_cli_velocities_option(arm, tmp_path, capsys):
    """--velocities logged on a log without velocity columns: one line, exit 2; the JSON says which were used."""
    import json

    from tendyn.cli import main
    from tendyn.io import write_log

    bare = write_log(synthetic_log(arm, duration=3.0), tmp_path / "bare.csv")
    assert main(["identify", str(arm.file), str(bare), "--velocities", "logged", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "qd_motor_" in err and len(err.strip().splitlines()) == 1
    full = write_log(synthetic_log(arm, duration=3.0, velocities=True), tmp_path / "full.csv")
    for opt, said in ((["--velocities", "differentiate"], "differentiate"), ([], "logged")):
        assert main(["identify", str(arm.file), str(full), "--json", "--quiet", *opt]) == 0
        assert json.loads(capsys.readouterr().out)["treatment"]["velocities"] == said


# -- 2. one velocity-threshold default, honoured by --stream -------------------------------------------------

@pytest.mark.parametrize("threshold", [None, 0.4])
def test_stream_honours_the_velocity_threshold(arm, tmp_path, threshold):
    """--stream and in memory agree, with the default threshold (a fraction of the peak speed) and a given one;
    and the threshold does change the fit (so agreeing is not agreeing on "no threshold")."""
    from tendyn.ident.stream import StreamingIDIM
    from tendyn.io import write_log

    log = synthetic_log(arm, rate_hz=1000.0, duration=10.0, seed=6, noise=0.01)
    path = write_log(log, tmp_path / "log.parquet")
    kw = dict(cutoff_hz=20.0, decimate=10, velocity_threshold=threshold)
    mem = IDIM(arm.device, **kw).fit(log, crossval=False)
    st = StreamingIDIM(arm.device, chunk_rows=1234, **kw).fit(path)
    assert st.result_.n_rows == mem.result_.n_rows
    np.testing.assert_allclose(st.treatment_.velocity_threshold, mem.treatment_.velocity_threshold, rtol=1e-9)
    np.testing.assert_allclose(st.params_, mem.params_, rtol=1e-7, atol=1e-9 * np.max(np.abs(mem.params_)))
    none = IDIM(arm.device, cutoff_hz=20.0, decimate=10, velocity_threshold=0.0).fit(log, crossval=False)
    assert none.result_.n_rows > mem.result_.n_rows


def test_cli_stream_passes_the_velocity_threshold(arm, tmp_path, capsys):
    import json

    from tendyn.cli import main
    from tendyn.io import write_log

    path = write_log(synthetic_log(arm, duration=6.0, seed=7, noise=0.01), tmp_path / "log.parquet")
    docs = []
    for extra in ([], ["--velocity-threshold", "0.5"]):
        assert main(["identify", str(arm.file), str(path), "--stream", "--json", *extra]) == 0
        docs.append(json.loads(capsys.readouterr().out))
    assert docs[1]["treatment"]["velocity_threshold"] == [0.5, 0.5]
    assert docs[0]["treatment"]["velocity_threshold"] != [0.0, 0.0]
    assert docs[1]["n_rows"] != docs[0]["n_rows"]


# -- 3. implausible values said ----------------------------------------------------------------------------

def test_negative_viscous_coefficient_is_flagged(arm, tmp_path, capsys):
    """A log whose joint 2 has a negative viscous term (a model that misses something): OLS returns FV2 < 0
    and says so in the table, the JSON and on stderr, naming FV2 and --consistent; the positive FV1 is not
    flagged; the physically consistent estimate has no warning."""
    import json

    from tendyn.cli import main
    from tendyn.io import write_log

    log = synthetic_log(arm, duration=8.0, seed=8, noise=0.01, fv=np.array([0.35, -0.05]))
    est = IDIM(arm.device, cutoff_hz=20.0, decimate=20).fit(log, crossval=False)
    fv2 = est.params_[est.names_.index("FV2")]
    assert fv2 < 0
    warn = {w.split(" ")[0]: w for w in est.result_.warnings if "is negative" in w}   # not the σ > value ones
    assert "FV2" in warn and "FV1" not in warn and "--consistent" in warn["FV2"]
    # every flagged value is negative and of a stem that must be positive (IAm2 = 0 in the truth may dip below)
    assert all(est.params_[est.names_.index(n)] < 0 and n.rstrip("0123456789") in ("FV", "FS", "IA", "IAm", "FVm",
               "FSm") for n in warn)
    assert "warning: FV2 = " in est.result_.table()
    path = write_log(log, tmp_path / "log.csv")
    assert main(["identify", str(arm.file), str(path), "--json", "--quiet", "--cutoff-hz", "20",
                 "--decimate", "20", "--plain"]) == 0     # the plain fit (the default reports the consistent one)
    out = capsys.readouterr()
    doc = json.loads(out.out)
    assert "FV2" in [w.split(" ")[0] for w in doc["warnings"]]
    assert "warning: FV2" in out.err
    cons = IDIM(arm.device, cutoff_hz=20.0, decimate=20, consistent=True).fit(log, crossval=False)
    assert [w for w in cons.result_.warnings if "σ exceeds" not in w and "to 10 %" not in w] == []   # σ notes only


# -- 1c. prismatic joints in SI ------------------------------------------------------------------------------

def mdh_device_toml(name, gravity, joints, ratios, bandwidth_hz=5.0) -> str:
    """A serial device file (modified DH, geared actuators) from joint rows ``(name, sigma, alpha, lower, upper,
    mass, com, inertia)`` in chain order: a generated device with prismatic joints."""
    lines = ["schema = 1", "[device]", f'name = "{name}"', 'description = "generated by the tests"',
             f"bandwidth_hz = {bandwidth_hz!r}", "[kinematics]", 'convention = "mdh"', f"gravity = {gravity!r}"]
    for j, (jn, sigma, alpha, lo, hi, mass, com, inertia) in enumerate(joints, start=1):
        lines += ["[[kinematics.joints]]", f'name = "{jn}"', f"j = {j}", f"antecedent = {j - 1}", "mu = 1",
                  f"sigma = {sigma}", f"alpha = {alpha!r}", "d = 0.0", "r = 0.0", f"lower = {lo!r}",
                  f"upper = {hi!r}", f"mass = {mass!r}", f"com = {com!r}", f"inertia = {inertia!r}"]
    for j, n in enumerate(ratios, start=1):
        lines += ["[[actuators]]", f"joint = {j}", f"ratio = {n!r}"]
    return "\n".join(lines) + "\n"


# a horizontal linear axis: one prismatic DOF driven by a linear motor
AXIS = mdh_device_toml("axis_gen", [0.0, -9.81, 0.0],
                       [("x", 1, 0.0, -0.3, 0.3, 2.5, [0.0, 0.0, 0.0], [0.01, 0.01, 0.01, 0.0, 0.0, 0.0])], [1.0])

MAP = """schema = 1
[log]
device = "axis_gen"
experiment = "exciting"
[[signals]]
column = "t"
signal = "time"
[[signals]]
column = "x_mm"
signal = "q_motor_1"
scale = 0.001
{unit_q}
[[signals]]
column = "force"
signal = "torque_motor_1"
{unit_f}
"""


def _axis_files(tmp_path, units=True):
    """A bench's CSV of the axis (position in mm, force in N at 500 Hz) and its import map; the truth:
    moving mass 3.1 kg, viscous 12 N·s/m, Coulomb 3 N, offset 1.5 N."""
    rate = 500.0
    t = np.arange(int(20 * rate)) / rate
    x = np.zeros_like(t); v = np.zeros_like(t); a = np.zeros_like(t)
    for k, (amp, f) in enumerate(((0.12, 0.4), (0.04, 1.1), (0.015, 2.3))):
        w = 2 * np.pi * f
        x += amp * np.sin(w * t + k); v += amp * w * np.cos(w * t + k); a -= amp * w * w * np.sin(w * t + k)
    force = 3.1 * a + 12.0 * v + 3.0 * np.tanh(v / 1e-4) + 1.5
    raw = tmp_path / "axis.csv"
    rows = zip(t.tolist(), (1000 * x).tolist(), force.tolist())
    raw.write_text("t,x_mm,force\n" + "".join(f"{a!r},{b!r},{c!r}\n" for a, b, c in rows))
    mp = tmp_path / "axis_import.toml"
    mp.write_text(MAP.format(unit_q='unit = "m"' if units else "", unit_f='unit = "N"' if units else ""))
    dev = tmp_path / "axis_gen.toml"
    dev.write_text(AXIS)
    return raw, mp, dev


def test_prismatic_axis_in_si_from_log_import_to_identify(tmp_path, capsys):
    """log import keeps metres and newtons (meta.units, the file's headers); identify labels the axis' terms
    kg, N·s/m and N and finds the truth the test built (3.1 kg moving, where the device file says 2.5 kg)."""
    import json

    from tendyn.cli import main
    from tendyn.io import read_log

    raw, mp, dev = _axis_files(tmp_path)
    out = tmp_path / "axis_log.csv"
    assert main(["log", "import", str(raw), "--map", str(mp), "--out", str(out)]) == 0
    capsys.readouterr()
    log = read_log(out)
    assert log.units["q_motor_1"] == "m" and log.units["torque_motor_1"] == "N"
    assert "q_motor_1 [m]" in out.read_text().splitlines()[1]
    assert main(["identify", str(dev), str(out), "--json", "--quiet"]) == 0
    doc = json.loads(capsys.readouterr().out)
    p = {q["name"]: q for q in doc["params"]}
    assert p["FV1"]["unit"] == "N·s/m" and p["FS1"]["unit"] == "N" and p["OFFSET1"]["unit"] == "N"
    assert p["M1R"]["unit"] == "kg"
    assert p["FV1"]["value"] == pytest.approx(12.0, rel=0.02)
    assert p["FS1"]["value"] == pytest.approx(3.0, rel=0.05)
    assert p["OFFSET1"]["value"] == pytest.approx(1.5, rel=0.05)
    assert p["M1R"]["value"] == pytest.approx(3.1, rel=0.02)


def test_prismatic_axis_logged_in_rad_is_refused(tmp_path, capsys):
    """The map route without units labels metres as rad: identify says which column and how to fix it."""
    from tendyn.cli import main

    raw, mp, dev = _axis_files(tmp_path, units=False)
    out = tmp_path / "axis_log.parquet"
    assert main(["log", "import", str(raw), "--map", str(mp), "--out", str(out)]) == 0
    capsys.readouterr()
    assert main(["identify", str(dev), str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "q_motor_1" in err and "prismatic joint 1" in err and 'unit = "m"' in err


def test_linear_units_on_a_revolute_joint_are_refused(arm):
    from tendyn.io import LogError

    log = synthetic_log(arm, duration=1.0)
    cols = dict(log.columns)
    lin = make_log(cols, device="x", rate_hz=1000.0, seed=None, experiment="e", units={"q_motor_2": "m"})
    with pytest.raises(LogError, match="q_motor_2.*revolute joint 2"):
        arm.joint_signals(lin)
    with pytest.raises(LogError, match="meta.units"):
        make_log(cols, device="x", rate_hz=1000.0, seed=None, experiment="e", units={"q_motor_2": "mm"})


def test_import_map_unit_errors(tmp_path):
    from tendyn.io import LogError
    from tendyn.io.importer import import_logs

    raw, mp, _ = _axis_files(tmp_path)
    mp.write_text(mp.read_text().replace('unit = "N"', 'unit = "kN"'))
    with pytest.raises(LogError, match=r"signals\[3\].unit: torque_motor_1 is in N·m or N"):
        import_logs([raw], mp)



# -- 4. the identified model as an object ------------------------------------------------------------------

def test_identified_model_saves_loads_and_predicts_a_new_log(arm, tmp_path):
    """Fit on one log, save, load, predict another log of the same device (another motion, stale rows in it,
    time stamps jittered by ±0.3 sample):
    one prediction per sample at the log's own time stamps, within 2 % of the truth's torques (which the test
    computes by RNEA, not by the regressor; with the true parameters the prediction is within 0.15 %), motor torques with Gᵀ y = τ; score is small on the device and large
    on a log of a device with other friction."""
    from tendyn.ident.identified import IdentifiedModel

    fit_log = synthetic_log(arm, duration=12.0, seed=11, noise=0.01)
    est = IDIM(arm.device, cutoff_hz=20.0, decimate=10).fit(fit_log, crossval=False)
    path = est.identified_model().save(tmp_path / "params.json")
    model = IdentifiedModel.load(path)
    new, _ = with_stale_rows(synthetic_log(arm, duration=6.0, seed=12, noise=0.01, jitter=0.3), 0.1, seed=3)
    pred = model.predict(new)
    assert pred.time.shape == new.time.shape and np.array_equal(pred.time, new.time)
    _, _, truth = true_torques(arm, new.time, 12)
    inner = slice(200, -200)      # the zero-phase filter's edges
    err = np.linalg.norm(pred.joint[inner] - truth[inner], axis=0) / np.linalg.norm(truth[inner], axis=0)
    assert np.all(err < 0.02), err
    np.testing.assert_allclose(pred.motor @ arm.G, pred.joint, atol=1e-9 * np.abs(pred.joint).max())
    other = synthetic_log(arm, duration=6.0, seed=12, noise=0.01, fv=3 * FV)
    # measured here: 4 % and 10 % (the torque noise, joint 2's torques are small) against 33 % and 58 %
    assert np.all(model.score(new) < 0.15)
    assert np.all(model.score(other) > 3 * model.score(new))
    assert pred.units == ["N·m", "N·m"] and type(pred.plot()).__name__ == "Figure"


def test_params_json_of_the_cli_loads_back_and_refuses_a_changed_device(arm, tmp_path, capsys):
    import json
    import shutil

    from tendyn.cli import main
    from tendyn.ident.identified import FORMAT, IdentifiedModel
    from tendyn.io import write_log

    dev = tmp_path / "arm.toml"
    shutil.copy(arm.file, dev)
    log = write_log(synthetic_log(arm, duration=6.0, seed=13, noise=0.01), tmp_path / "log.csv")
    out = tmp_path / "params.json"
    assert main(["identify", str(dev), str(log), "--out", str(out), "--quiet"]) == 0
    capsys.readouterr()
    doc = json.loads(out.read_text())
    assert doc["format"] == FORMAT and len(doc["device_sha256"]) == 64 and doc["device_file"] == str(dev)
    model = IdentifiedModel.load(out)
    assert np.all(model.score(log) < 0.3)
    dev.write_text(dev.read_text() + "\n# edited\n")
    with pytest.raises(ValueError, match="another version"):
        IdentifiedModel.load(out)


def test_cli_validate(arm, tmp_path, capsys):
    """tendyn validate: per-log, per-joint relative errors (JSON, table, a figure per log); a log of the
    same arm with other friction scores worse; a bad PARAMS.json is one line, exit 2."""
    import json

    from tendyn.cli import main
    from tendyn.io import write_log

    fit = write_log(synthetic_log(arm, duration=8.0, seed=21, noise=0.01), tmp_path / "fit.csv")
    same = write_log(synthetic_log(arm, duration=4.0, seed=22, noise=0.01), tmp_path / "same.parquet")
    other = write_log(synthetic_log(arm, duration=4.0, seed=22, noise=0.01, fv=3 * FV), tmp_path / "other.csv")
    params = tmp_path / "params.json"
    assert main(["identify", str(arm.file), str(fit), "--out", str(params), "--quiet"]) == 0
    capsys.readouterr()
    rep = tmp_path / "rep"
    assert main(["validate", str(arm.file), str(params), str(same), str(other), "--json", "--report", str(rep)]) == 0
    doc = json.loads(capsys.readouterr().out)
    e_same, e_other = (np.array(d["relative_error"]) for d in doc["logs"])
    assert e_same.shape == (2,) and np.all(e_other > 2 * e_same)
    assert (rep / "table.txt").is_file() and (rep / "same.png").is_file() and (rep / "other.png").is_file()
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"params": [{"name": "ZZ1R", "value": "x", "expression": "ZZ1"}]}))
    assert main(["validate", str(arm.file), str(bad), str(same)]) == 2
    err = capsys.readouterr().err.strip()
    assert "params[0].value" in err and len(err.splitlines()) == 1


def test_validate_and_predict_apply_the_device_check_of_identify(arm, tmp_path, capsys):
    """Issue 34 item 5: validate, IdentifiedModel.load and IdentifiedModel.predict refuse a PARAMS.json or a log of
    another device unless --force / force=True, and a PARAMS.json with a parameter missing or unknown always (it
    printed per-joint errors and exit 0)."""
    import json

    from tendyn.cli import main
    from tendyn.ident.identified import IdentifiedModel
    from tendyn.io import LogError, write_log
    from tendyn.io.params import ParamsError

    fit = write_log(synthetic_log(arm, duration=6.0, seed=31), tmp_path / "fit.csv")
    params = tmp_path / "params.json"
    assert main(["identify", str(arm.file), str(fit), "--out", str(params), "--quiet"]) == 0
    capsys.readouterr()
    doc = json.loads(params.read_text())
    variants = {"other_device": dict(doc, device="L-EXOS"),
                "missing": dict(doc, params=doc["params"][1:]),
                "unknown": dict(doc, params=doc["params"] + [dict(doc["params"][0], name="ZZ9R", expression="ZZ9")])}
    for name, bad in variants.items():
        path = tmp_path / f"{name}.json"
        path.write_text(json.dumps(bad))
        assert main(["validate", str(arm.file), str(path), str(fit)]) == 2, name
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("tendyn: error:"), err
        with pytest.raises(ParamsError):
            IdentifiedModel.load(path, device=arm.device)
    path = tmp_path / "other_device.json"
    assert main(["validate", str(arm.file), str(path), str(fit), "--force"]) == 0
    capsys.readouterr()
    # a log of another device
    other = synthetic_log(arm, duration=2.0, seed=32)
    other.meta["device"] = "L-EXOS"
    other_path = write_log(other, tmp_path / "otherdev.csv")
    assert main(["validate", str(arm.file), str(params), str(other_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "otherdev.csv" in err[0] and "'L-EXOS'" in err[0] and "--force" in err[0], err
    assert main(["validate", str(arm.file), str(params), str(other_path), "--force"]) == 0
    capsys.readouterr()
    model = IdentifiedModel.load(params, device=arm.device)
    with pytest.raises(LogError, match="L-EXOS"):
        model.predict(other)
    assert IdentifiedModel.load(params, device=arm.device, force=True).predict(other).joint.shape[1] == 2


def test_cli_validate_record_goes_into_the_history(arm, tmp_path, capsys):
    """Issue 23: `tendyn validate --record` adds per joint relative_error[j] (over the logs, sample-weighted RMS)
    to the calibration history next to identify's parameters; a log with 3x the friction shows as a rise in
    `tendyn history`; --db without --record is refused before any work."""
    import json

    from tendyn.cli import main
    from tendyn.io import write_log

    fit = write_log(synthetic_log(arm, duration=8.0, seed=21, noise=0.01), tmp_path / "fit.csv")
    same = write_log(synthetic_log(arm, duration=4.0, seed=22, noise=0.01), tmp_path / "same.csv")
    other = write_log(synthetic_log(arm, duration=4.0, seed=22, noise=0.01, fv=3 * FV), tmp_path / "other.csv")
    params, db = tmp_path / "params.json", tmp_path / "h.sqlite"
    assert main(["identify", str(arm.file), str(fit), "--out", str(params), "--quiet", "--record", "--db",
                 str(db)]) == 0
    docs = []
    for log in (same, other):
        capsys.readouterr()
        assert main(["validate", str(arm.file), str(params), str(log), "--json", "--record", "--db", str(db)]) == 0
        docs.append(json.loads(capsys.readouterr().out))
    assert main(["history", str(arm.file), "--db", str(db), "--json"]) == 0
    rows = [r for r in json.loads(capsys.readouterr().out)["rows"] if r["kind"] == "validate"]
    assert [r["name"] for r in rows] == ["relative_error[1]", "relative_error[2]"] * 2
    logged = [e for d in docs for e in d["logs"][0]["relative_error"]]   # one log each: the metric is its error
    np.testing.assert_allclose([r["value"] for r in rows], logged, rtol=1e-12)
    assert rows[2]["value"] > 2 * rows[0]["value"] and all(r["sigma"] is None for r in rows)
    code = main(["validate", str(arm.file), str(params), str(same), "--db", str(db)])
    assert code == 2 and "--db needs --record" in capsys.readouterr().err


# a vertical prismatic joint carrying a revolute one
MIXED = mdh_device_toml("mixed_gen", [0.0, 0.0, -9.81],
                        [("z", 1, 0.0, -0.3, 0.3, 1.8, [0.0, 0.0, -0.05], [0.01, 0.01, 0.01, 0.0, 0.0, 0.0]),
                         ("q2", 0, 1.5707963267948966, -3.0, 3.0, 0.6, [0.12, 0.0, 0.0],
                          [0.002, 0.004, 0.004, 0.0, 0.0, 0.0])], [1.0, 10.0], bandwidth_hz=10.0)


def test_mixed_prismatic_and_revolute_device(tmp_path):
    """A vertical prismatic joint carrying a revolute one: joint 1's terms in N·s/m and N, joint 2's in
    N·m·s/rad and N·m; the logged columns of motor 1 in m and N; the friction identified near the truth."""
    dev = tmp_path / "mixed_gen.toml"
    dev.write_text(MIXED)
    m = IdentModel(load_device(dev))
    log = synthetic_log(m, duration=12.0, seed=31, noise=0.005)
    assert log.units["q_motor_1"] == "m" and log.units["torque_motor_2"] == "N·m"
    est = IDIM(m.device, cutoff_hz=20.0, decimate=10, velocity_threshold=0.0).fit(log, crossval=False)
    units = dict(zip(est.names_, est.result_.units))
    assert units["FV1"] == "N·s/m" and units["FS1"] == "N" and units["FV2"] == "N·m·s/rad" and units["FS2"] == "N·m"
    for k, n in enumerate(("FV1", "FV2")):
        assert est.params_[est.names_.index(n)] == pytest.approx(FV[k], rel=0.05)
    assert torque_error(m, est, synthetic_log(m, duration=12.0, seed=31)) < 0.01


# -- 5. treatment defaults printed with why ----------------------------------------------------------------

def test_treatment_says_where_each_setting_came_from():
    from tendyn.ident.treatment import DEFAULT_VELOCITY_FRACTION, default_treatment

    tr = default_treatment(1000.0, 10.0, velocity_threshold=None)
    assert tr.cutoff_hz == 50.0 and tr.decimate == 10
    text = tr.describe()
    assert "cut-off 5 x the bandwidth (50 Hz)" in text and "decimation to about 10 x the bandwidth (100 Hz)" in text
    assert f"{100 * DEFAULT_VELOCITY_FRACTION:g} % of each joint's peak speed" in text
    slow = default_treatment(200.0, 10.0, velocity_threshold=None)      # 5 x 10 Hz is above a tenth of 200 Hz
    assert slow.cutoff_hz == 20.0 and "cut-off a tenth of the rate (20 Hz" in slow.describe()
    given = default_treatment(1000.0, None, cutoff_hz=30.0, decimate=4, velocity_threshold=0.1)
    assert given.why == ("the device file gives no bandwidth_hz, 10 Hz assumed", "cut-off given",
                         "decimation given", "velocity threshold given")
    assert given.to_dict()["why"] == list(given.why)


def test_stream_on_a_prismatic_axis(tmp_path, capsys):
    """--stream checks the file's units and labels the axis in SI as in memory."""
    import json

    from tendyn.cli import main

    raw, mp, dev = _axis_files(tmp_path)
    out = tmp_path / "axis.parquet"
    assert main(["log", "import", str(raw), "--map", str(mp), "--out", str(out)]) == 0
    capsys.readouterr()
    docs = []
    for extra in (["--stream"], []):
        assert main(["identify", str(dev), str(out), "--json", "--quiet", *extra]) == 0
        docs.append({p["name"]: p for p in json.loads(capsys.readouterr().out)["params"]})
    assert docs[0]["FV1"]["unit"] == "N·s/m" and docs[0]["OFFSET1"]["unit"] == "N"
    assert docs[0]["FV1"]["value"] == pytest.approx(docs[1]["FV1"]["value"], rel=1e-6)
    raw, mp, dev = _axis_files(tmp_path, units=False)
    assert main(["log", "import", str(raw), "--map", str(mp), "--out", str(out)]) == 0
    capsys.readouterr()
    assert main(["identify", str(dev), str(out), "--stream", "--quiet"]) == 2
    assert "prismatic joint 1" in capsys.readouterr().err


# -- one estimator contract --------------------------------------------------------------------------------

def test_estimators_share_the_contract(arm, tmp_path):
    """IDIM and StreamingIDIM: get_params gives the __init__ arguments (a clone fits the same), set_params
    refuses an unknown name, predict gives a time series at the log's stamps and score per-joint errors; the
    streamed fit predicts like the in-memory one."""
    from tendyn.ident.stream import StreamingIDIM
    from tendyn.io import write_log

    log = synthetic_log(arm, duration=6.0, seed=41, noise=0.01)
    path = write_log(log, tmp_path / "log.parquet")
    est = IDIM(arm.device, cutoff_hz=20.0, decimate=10, velocity_threshold=0.0)
    assert est.get_params()["cutoff_hz"] == 20.0 and "velocities" in est.get_params()
    clone = IDIM(**est.get_params())
    np.testing.assert_array_equal(clone.fit(log, crossval=False).params_, est.fit(log, crossval=False).params_)
    with pytest.raises(ValueError, match="no parameter 'cutof'"):
        est.set_params(cutof=3.0)
    assert est.set_params(order=4) is est
    cv = IDIM(arm.device, cutoff_hz=20.0, decimate=10).fit(log).result_
    per = cv.crossval["per_joint_residual_rel"]
    assert f"(per joint: 1: {100 * per[0]:.2f} %, 2: {100 * per[1]:.2f} %)" in cv.table()
    st = StreamingIDIM(arm.device, cutoff_hz=20.0, decimate=10, velocity_threshold=0.0).fit(path)
    assert set(st.get_params()) == {"device", "method", "cutoff_hz", "decimate", "order", "chunk_rows",
                                    "velocity_threshold", "velocities"}
    a, b = est.predict(log), st.predict(log)
    assert np.array_equal(a.time, log.time) and a.joint.shape == (log.n_samples, 2)
    np.testing.assert_allclose(b.joint, a.joint, rtol=1e-6, atol=1e-8 * np.abs(a.joint).max())
    np.testing.assert_allclose(st.score(log), est.score(log), rtol=1e-6)


def test_precision_warnings_are_told_from_sign_faults():
    """The 'plain least squares is not physical' line names the sign faults only (what the consistent fit answers):
    precision_warning tells implausible's σ warnings (not pinned) from its sign faults (not physical)."""
    from tendyn.ident.result import implausible, precision_warning

    w = implausible(["FV1", "FV2", "IA3"], [-0.1, 0.1, 0.001], [0.01, 0.02, 0.002])
    assert len(w) == 3
    assert [precision_warning(x) for x in w] == [False, True, True]
