"""Issue 30, item 4: bench models that hold across amplitudes (ident/blockmodel.py).

A model fitted to a PRBS record at one amplitude A predicts records at 0.5 A and 1.5 A (never seen by the fit)
with NRMS at most 1.2 times its own fit's. The data come from the McGill twin and from generated benches (the
C++ tendon-bench simulator, sim/tendon_bench: two motors, class-B split, Coulomb friction at each node, linear
in tension); the estimator sees only the logs' (u, y). The push-pull Lur'e model (two Lur'e loops of one G and
one friction level fed the half-waves) holds; the one-loop Lur'e model does not at half the amplitude on the
McGill twin — the test that shows the criterion can fail. Records of 4 s at 1 kHz: shorter ones let one record's detail (the twin's tension-dependent friction)
move the ratio by ±0.3. The Lur'e fits are scalar recursions (≈ 1 µs a sample in Python): the McGill test takes
≈ 10 s. On generated benches the constant-level model misses (1.21–1.35×); the ``coulomb-tension`` model (level
linear in the branch's output, 4 recursion steps a sample) holds: one generated bench in the fast suite, the
others and the McGill twin marked slow (the same code path)."""

from __future__ import annotations

import contextlib
import io
import json

import pytest

from tendyn.device.tendon_bench import load_tendon_bench
from tendyn.devices import bundled
from tendyn.ident.blockmodel import BlockModel
from tendyn.pipelines import s1_logs

DURATION_S = 4.0
AMPLITUDE_N = 1.0


def _records(bench, seed):
    logs = s1_logs.prbs_logs(bench, (AMPLITUDE_N, 0.5 * AMPLITUDE_N, 1.5 * AMPLITUDE_N), seed, DURATION_S)
    return logs, s1_logs.bench_records(logs)


@pytest.fixture(scope="module")
def mcgill():
    return load_tendon_bench(bundled("mcgill_bench"))


@pytest.fixture(scope="module")
def mcgill_records(mcgill):
    return _records(mcgill, 300)


def _ratios(model, recs):
    return [model.nrms(r.u, r.y) / model.fit_nrms_ for r in recs[1:]]


def test_push_pull_model_holds_at_half_and_one_and_a_half_the_amplitude_on_the_mcgill_twin(mcgill, mcgill_records):
    """Fitted at 1 N only: NRMS at 0.5 N and 1.5 N within 1.2× the fit's; the friction level of one branch is the
    twin's node friction F_c = F_c0 + μ_T T_pre (0.125 N) within 5 %. The one-loop Lur'e model of the same
    record misses the 0.5 N record by more than 1.2× (its one friction cannot be both motors' nodes)."""
    _, recs = mcgill_records
    pp = BlockModel("push-pull", "coulomb", order=2).fit(recs[:1])
    assert max(_ratios(pp, recs)) <= 1.2, _ratios(pp, recs)
    assert pp.fit_nrms_ < 0.05
    fc = mcgill.friction_c0 + mcgill.friction_mu_tension * mcgill.pretension
    assert pp.params_["level"] == pytest.approx(fc, rel=0.05)
    one = BlockModel("lure", "coulomb", order=2).fit(recs[:1])
    assert max(_ratios(one, recs)) > 1.2


def _generated(mcgill, changes):
    bench = mcgill.replace(**changes)
    fc = bench.friction_c0 + bench.friction_mu_tension * bench.pretension
    recs = s1_logs.bench_records(s1_logs.prbs_logs(bench, (8 * fc, 4 * fc, 12 * fc), 400, DURATION_S))
    return bench, fc, recs


def test_tension_model_holds_across_amplitudes_on_a_generated_bench(mcgill):
    """A generated bench (three times the McGill damping), A = 8 F_c: ``coulomb-tension`` (push-pull, level
    F + μ s y per branch, 4 recursion steps a sample) predicts 0.5 A and 1.5 A within 1.2× its fit's NRMS
    (measured 1.10/1.15; the constant level misses 1.5 A at 1.35×, its stick/slip decisions taken at the 1 kHz
    log rate where the twin's are at 20 kHz and its level blind to the tension: the slow test below), F =
    F_c0 + μ_T T_pre within 3 % and μ of the twin's μ_T's size (0.0065 against 0.005). 7–12 s on the shared
    machine: the constant-level fit (the start) and the tension fit, both Python recursions over 4 000 samples."""
    bench, fc, recs = _generated(mcgill, dict(damping_motor=30.0))
    tens = BlockModel("push-pull", "coulomb-tension", order=2).fit(recs[:1])
    assert max(_ratios(tens, recs)) <= 1.2, _ratios(tens, recs)
    assert tens.fit_nrms_ < 0.01
    assert tens.params_["level"] == pytest.approx(fc, rel=0.03)
    assert 0.5 * bench.friction_mu_tension < tens.params_["per_output"] < 2.0 * bench.friction_mu_tension


@pytest.mark.slow
def test_constant_level_misses_the_generated_bench(mcgill):
    """The same bench and records: the constant-level push-pull model misses by more than 1.2× (measured 1.35)."""
    bench, fc, recs = _generated(mcgill, dict(damping_motor=30.0))
    const = BlockModel("push-pull", "coulomb", order=2).fit(recs[:1])
    assert max(_ratios(const, recs)) > 1.2, _ratios(const, recs)


@pytest.mark.slow
@pytest.mark.parametrize("changes", [
    dict(friction_c0=0.2, name="more friction"),
    dict(mass_motor=0.35, k1=4.0e4, pretension=8.0, friction_c0=0.06, name="lighter, stiffer"),
    dict(damping_motor=30.0, name="damped"),
    dict(name="mcgill"),
])
def test_push_pull_model_across_amplitudes_on_generated_benches(mcgill, changes):
    """At A = 8 F_c (the McGill twin's 1 N): ``coulomb-tension`` has its level within 3 % of F_c and the records
    at 0.5 A and 1.5 A within the 1.2× of issue 30 (measured 0.95/1.15, 0.89/1.11, 1.10/1.15; the constant level:
    1.23/1.09, 1.29/1.10, 1.21/1.35, docs/bench-identification.md)."""
    bench, fc, recs = _generated(mcgill, changes)
    pp = BlockModel("push-pull", "coulomb-tension", order=2).fit(recs[:1])
    assert pp.params_["level"] == pytest.approx(fc, rel=0.03)
    assert max(_ratios(pp, recs)) <= 1.2, (changes, _ratios(pp, recs))


def test_identify_bench_auto_chooses_the_structure_on_another_amplitude(mcgill_records, tmp_path):
    """`identify-bench --structure auto --validate` (validation at 0.5 A): the push-pull Lur'e model wins over
    the Wiener dead-zone and the one-loop Lur'e, and the JSON says each candidate's validation NRMS."""
    from tendyn.cli import main
    from tendyn.io import write_log

    logs, _ = mcgill_records
    paths = []
    for k, lg in enumerate(logs[:2]):
        paths.append(tmp_path / f"prbs{k}.csv")
        write_log(lg, paths[-1])
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["identify-bench", str(paths[0]), "--validate", str(paths[1]), "--structure", "auto",
                     "--order", "2", "--shift", "1", "--json"])
    assert code == 0, err.getvalue()
    doc = json.loads(out.getvalue())
    assert doc["structure"] == "push-pull"
    assert set(doc["structure_nrms"]) == {"wiener dead-zone", "lure coulomb", "push-pull coulomb",
                                          "push-pull coulomb-tension"}
    assert doc["structure_nrms"][f"push-pull {doc['nonlinearity']}"] == min(doc["structure_nrms"].values())


def test_identify_bench_needs_a_nonlinearity_unless_auto(mcgill_records, tmp_path):
    from tendyn.cli import main
    from tendyn.io import write_log

    logs, _ = mcgill_records
    p = tmp_path / "a.csv"
    write_log(logs[0], p)
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(["identify-bench", str(p), "--validate", str(p), "--structure", "lure"])
    assert code == 2 and "--nonlinearity" in err.getvalue() and "\n" == err.getvalue()[-1]
    assert err.getvalue().count("\n") == 1
