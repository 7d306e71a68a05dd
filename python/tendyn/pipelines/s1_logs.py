"""S1 from the logs a bench records (issue 21, item 4): Ĝ_L, the dead-band and the loop area obtained from
the McGill twin's *logs* (``force_cmd`` → ``force_tendon``) by the routes a real bench would use; the twin's
internals (its linear plant G(s) of S1 eq. 2 and its node friction) serve only as the truth the results are
compared with.

* Ĝ_L: stepped-sine logs at :data:`~tendyn.pipelines.s1.LARGE_AMPLITUDE_N` (one log per frequency, references
  of :func:`tendyn.sim.excitation.stepped_sines`), H1 at each tone (:func:`tendyn.ident.frf.frf_from_logs`),
  P̂ = g/(a s² + b s + 1) fitted to it (:func:`tendyn.control.loop_shaping.fit_plant_frf`).
* The dead-band: PRBS logs at three amplitudes (:func:`tendyn.sim.excitation.prbs`, the controller's 1 kHz
  hold), a Wiener model G(z) → dead-zone fitted by output error (:class:`tendyn.ident.blockmodel.BlockModel`,
  S1 Fig. 8), validated by simulation on PRBS logs at two other amplitudes (NRMS). Its linear block is
  compared with G(s), its half-width δ with the twin's dead-band 2 F_c (the class-B half-waves against the
  Coulomb node friction at rest, F_c = F_c0 + μ_T T_pre; ``sim/tendon_bench`` conventions).
* The friction inside the dynamics: a Lur'e model on the same logs (:func:`lure_fit`), G(z) with Coulomb
  friction of level F fed back to its input (the twin's node friction acts there: it damps the motion, which
  the Wiener model's G absorbs), fitted by output error. Its linear block is compared with G(s) and F — the
  half-width of the dead-band seen from the command, static balance |u − y/G(1)| ≤ F — with the same
  2 F_c. Summary key ``lure`` beside ``wiener``.
* The loop area: the 0.2 Hz / 0.31 N low-speed log (S1 Fig. 10b), |∮ F_m dF_τ| normalised
  (:func:`tendyn.pipelines.s1.loop_area`) from the log's two columns.

Log alignment: the twin logs every 20th step (1 kHz); the logged command u_k is the one held during the
millisecond that ends at the logged output y_k, so y_k = Σ_{j≤k} g_{k+1−j} u_j (z G_zoh in log samples).
The block model is fitted on (u_{k+1}, y_k), where the standard zero-order-hold relation y = G_zoh u holds and
its continuous equivalent is G(s) itself.
"""

from __future__ import annotations

import math

import numpy as np

from tendyn.ident.blockmodel import BlockModel, records_from_logs
from tendyn.ident.frf import frf_from_logs
from tendyn.sim import excitation
from tendyn.sim.catalogue import PRBS_CLOCK_HZ
from tendyn.sim.tendon_bench import bench_log, simulate

__all__ = ["LOG_RATE_HZ", "PRBS_AMPLITUDES", "bench_records", "lure_fit", "prbs_logs", "record_log", "s1_from_logs",
           "stepped_sine_logs"]

SIM_RATE_HZ = 20000.0
"""Step rate of the twin [Hz]."""
LOG_RATE_HZ = 1000.0
"""Rate of the logs and of the PRBS references (a bench controller's rate) [Hz]."""
PRBS_AMPLITUDES = (0.5, 1.0, 2.0)
"""PRBS levels ±A [N] of the estimation logs (the dead-band ≈ 0.25 N to well above it)."""
VALIDATION_AMPLITUDES = (0.4, 1.5)
"""PRBS levels [N] of the validation logs."""
PRBS_DURATION_S = 12.0
BAND_HZ = (2.0, 20.0)
"""Band [Hz] in which the identified linear block is compared with G(s) (inside the PRBS's flat power)."""


def _held(reference: np.ndarray, rate_hz: float) -> np.ndarray:
    """A reference at ``rate_hz`` held at the twin's step rate (the controller's zero-order hold)."""
    k = SIM_RATE_HZ / rate_hz
    return np.repeat(reference, int(round(k)))


def record_log(bench, reference: np.ndarray, rate_hz: float, experiment: str, options: dict, seed: int):
    """Run ``reference`` (sampled at ``rate_hz``, held at the step rate) on the twin; its log at
    :data:`LOG_RATE_HZ`."""
    run = simulate(bench, _held(reference, rate_hz), SIM_RATE_HZ, seed=seed)
    return bench_log(bench, run, experiment, options, int(round(SIM_RATE_HZ / LOG_RATE_HZ)))


def bench_records(logs) -> list:
    """Block-model records (u_{k+1}, y_k) of the twin's logs (module docstring: the log alignment)."""
    return records_from_logs(logs, "force_cmd", "force_tendon", shift=1)[0]


def prbs_logs(bench, amplitudes, seed0: int, duration_s: float = PRBS_DURATION_S) -> list:
    """PRBS logs ±A for each A of ``amplitudes`` [N] (references at the logs' rate, seeds seed0, seed0 + 1, …)."""
    return [record_log(bench, excitation.prbs(a, duration_s, LOG_RATE_HZ, clock_hz=PRBS_CLOCK_HZ, seed=seed0 + k),
                       LOG_RATE_HZ, "prbs", {"amplitude_N": a, "clock_hz": PRBS_CLOCK_HZ}, seed0 + k)
            for k, a in enumerate(amplitudes)]


def stepped_sine_logs(bench, freqs_hz, amplitude_N: float, cycles: int = 8, settle_s: float = 0.6) -> list:
    """One log per frequency [Hz]; the sines are sampled at the twin's step rate (a sine needs no hold)."""
    refs = excitation.stepped_sines(amplitude_N, freqs_hz, SIM_RATE_HZ, cycles=cycles, settle_s=settle_s)
    return [record_log(bench, u, SIM_RATE_HZ, "stepped_sine", {"freq_hz": float(f), "amplitude_N": amplitude_N}, k)
            for k, (f, u) in enumerate(zip(np.ravel(freqs_hz), refs))]


def lure_fit(estimation_logs, validation_logs, order: int = 2):
    """The Lur'e model (G(z) of ``order``, Coulomb friction in its feedback: ``BlockModel("lure", "coulomb")``)
    fitted by output error to the twin's logs, validated by simulation on ``validation_logs``; its
    :class:`~tendyn.ident.blockmodel.BlockModelFit` (units N → N, ``params["level"]`` the friction level
    F [N] = the dead-band's half-width)."""
    model = BlockModel("lure", "coulomb", order=order).fit(bench_records(estimation_logs),
                                                           validation=bench_records(validation_logs))
    res = model.result_
    res.units = {"input": "N", "output": "N"}
    return res


def _linear_errors(model, truth_G, frf_freq_hz) -> dict:
    """Relative errors of a block model's linear part, made continuous, against G(s): the max in
    :data:`BAND_HZ` and at the stepped-sine frequencies [Hz]."""
    from tendyn.control.loop_shaping import freqresp

    w = 2 * math.pi * np.linspace(BAND_HZ[0], BAND_HZ[1], 50)
    lin = model.linear_continuous()
    g = freqresp(truth_G, omega=w)
    wf = 2 * math.pi * np.asarray(frf_freq_hz, float)
    gf = freqresp(truth_G, omega=wf)
    return {"linear_max_rel_error_in_band": float(np.max(np.abs(freqresp(lin, omega=w) - g) / np.abs(g))),
            "linear_rel_error_vs_G": {f"{f:g}": float(e) for f, e in zip(
                frf_freq_hz, np.abs(freqresp(lin, omega=wf) - gf) / np.abs(gf))}}


def s1_from_logs(bench, *, freqs_hz, large_amplitude_N: float, truth_G=None, dead_band_truth_N: float | None = None):
    """The logs route (module docstring). Returns ``(summary dict, plant fit, Wiener fit, logs dict)``.

    ``truth_G`` (python-control TF) and ``dead_band_truth_N`` are the twin's internals, used only to report
    the errors of what the logs gave."""
    from tendyn.control.loop_shaping import fit_plant_frf, freqresp
    from tendyn.pipelines.s1_loops import loop_area
    from tendyn.sim.tendon_bench import LOW_SPEED_FREQ_HZ

    # Ĝ_L from stepped-sine logs at large amplitude
    steps = stepped_sine_logs(bench, freqs_hz, large_amplitude_N)
    frf = frf_from_logs(steps, "force_cmd", "force_tendon")
    fit = fit_plant_frf(frf.omega, frf.h1, amplitude_N=large_amplitude_N)
    # the dead-band: a Wiener model by output error on PRBS logs, validated on others
    est, val = prbs_logs(bench, PRBS_AMPLITUDES, 100), prbs_logs(bench, VALIDATION_AMPLITUDES, 200, 6.0)
    model = BlockModel("wiener", "dead-zone", order=2).fit(bench_records(est), validation=bench_records(val))
    wiener = model.result_
    wiener.units = {"input": "N", "output": "N"}
    # the friction inside the dynamics: a Lur'e model on the same logs
    lure = lure_fit(est, val)
    # the loop area from the low-speed log (0.2 Hz, 0.31 N: S1 Fig. 10b), the last of two cycles
    n = int(round(2 / LOW_SPEED_FREQ_HZ * SIM_RATE_HZ))
    slow_u = 0.31 * np.sin(2 * math.pi * LOW_SPEED_FREQ_HZ * (np.arange(n) + 0.5) / SIM_RATE_HZ)
    slow = record_log(bench, slow_u, SIM_RATE_HZ, "low_speed_loop", {"freq_hz": LOW_SPEED_FREQ_HZ, "amplitude_N": 0.31},
                      0)
    half = slow.n_samples // 2
    summary = {
        "plant_fit": fit.to_dict(),
        "frf": {"freq_hz": frf.freq_hz.tolist(), "coherence_min": float(frf.coherence.min()),
                "logs": len(steps)},
        "wiener": {"dead_band_N": wiener.params["width"], "order": wiener.order, "fit_nrms": wiener.fit_nrms,
                   "validation_nrms": wiener.validation_nrms, "validation_amplitudes_N": list(VALIDATION_AMPLITUDES),
                   "prbs_amplitudes_N": list(PRBS_AMPLITUDES), "prbs_clock_hz": PRBS_CLOCK_HZ,
                   "seconds": wiener.seconds},
        "lure": {"dead_band_N": lure.params["level"], "coulomb_level_N": lure.params["level"], "order": lure.order,
                 "fit_nrms": lure.fit_nrms, "validation_nrms": lure.validation_nrms, "seconds": lure.seconds},
        "loop_area": loop_area(slow["force_cmd"][half:], slow["force_tendon"][half:]),
        "band_hz": list(BAND_HZ),
    }
    if truth_G is not None:
        w = 2 * math.pi * np.linspace(BAND_HZ[0], BAND_HZ[1], 50)
        g = freqresp(truth_G, omega=w)
        summary["plant_fit"]["max_rel_error_vs_G_in_band"] = float(np.max(np.abs(fit.response(omega=w) - g) / np.abs(g)))
        for key, m in (("wiener", wiener), ("lure", lure)):
            summary[key].update(_linear_errors(m, truth_G, frf.freq_hz))
    if dead_band_truth_N is not None:
        for key, m in (("wiener", wiener), ("lure", lure)):
            d = summary[key]["dead_band_N"]
            summary[key]["dead_band_truth_N"] = dead_band_truth_N
            summary[key]["dead_band_rel_error"] = (abs(d - dead_band_truth_N) / dead_band_truth_N
                                                   if dead_band_truth_N > 0 else None)
    return summary, fit, wiener, {"stepped_sine": steps, "prbs": est, "validation": val, "low_speed": slow}
