"""Is the model adequate for this log?  Simulation fit against the measurement-noise floor, and residual tests.

The residual of the TRUE model is pure measurement error (shared/notes/model.md, "Measured facts for the
adequacy verdict"): its RMS sits at the noise floor (the estimated white-noise sigma, or q/sqrt(12) for an
encoder).  A wrong model leaves angle errors well above that floor, correlated with the inputs.  Quantisation
at high sample rates makes even the true model's residual coloured (the angle stays on one code for many
samples), so the residual tests run on the residual decimated to DECIMATED_RATE_HZ, where that colour has
gone, and they only count when the residual is above the numerical floor (a noise-free simulated log fits to
~1e-12 rad; the correlation of round-off says nothing about the physics).

The verdict: adequate when both angles' error RMS is within RMS_OVER_NOISE of their noise floor.  The
whiteness test and the residual-input cross-correlation test (the tests MATLAB's ``resid`` draws) are
reported with their statistics and thresholds, as evidence of where a misfit lies, but do not decide:
measured on 16 logs of the true model (12-bit and 0.5 mrad, 100 Hz-1 kHz, from rest, mid-run, jittered),
the cross-correlation test at 99 % still rejected 3 (statistic 54-98 against 45.6, after Bartlett's
correction), while the RMS ratio was 0.97-1.01 on all of them and 1.3-26 000 on every wrong model tried
(missing cable, Coulomb friction, the other thrust law, Mg, k2, kc, Kg off by 6-20 %).

The residual tests apply only where the angle carries measurable noise (its floor at SMOOTHED_FLOOR_RAD or
above): on smoothed or noise-free angles the residual is the integrator's or the smoothing's error, coloured
whatever the model (a noise-free simulated square left Q = 6 300 against 44 under a fitting verdict), so there
they are marked as not applying (``applies`` false, ``white``/``uncorrelated`` None) rather than failed.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.special import chdtri  # scipy.stats would add 0.7 s to every start-up

from .blackbox import MIN_FIT_PERCENT

#: angle error RMS within this factor of the noise floor: clean logs measured 0.93-1.01 (36 benchmark cells)
RMS_OVER_NOISE = 1.2
#: residual tests run on the residual decimated to about this rate [Hz]
DECIMATED_RATE_HZ = 25.0
LAGS = 25
LEVEL = 0.99
#: below this RMS [rad] the fit is exact to the integrator; residual tests are not meaningful, and no angle is
#: judged against a floor below it: a noise-free simulated log (the CE150's published runs measure 8e-11 rad) is
#: fitted to 2e-8-5e-8 rad by its own model, the integrator's and the input hold's error, not a misfit
NUMERICAL_FLOOR_RAD = 1e-7
#: a measured noise floor below this [rad] is finer than any encoder up to 20 bits leaves (a 20-bit encoder's
#: rounding q/sqrt(12) is 1.7e-6 rad, the TRMS's 4096-line one 4.4e-4 rad): the angles were smoothed or
#: interpolated before they were logged (the real CE150 recordings measure 8e-11 to 1.2e-6 rad), or the log is
#: simulated without noise.  The floor is then a lower bound the log cannot measure, and the verdict does not
#: rest on it (model_check: a black-box model's held-out error is the floor instead).
SMOOTHED_FLOOR_RAD = 1.5e-6
ANGLES = ("alpha", "beta")
AXIS_OF = {"alpha": "pitch", "beta": "yaw"}


def nrmse_fit_percent(y: np.ndarray, yhat: np.ndarray) -> float:
    """100 (1 - ||y - yhat|| / ||y - mean(y)||), the fit of MATLAB's ``compare``."""
    spread = float(np.linalg.norm(y - y.mean()))
    return 100.0 * (1.0 - float(np.linalg.norm(y - yhat)) / spread) if spread > 0 else math.nan


def ljung_box(e: np.ndarray, lags: int = LAGS) -> float:
    """Q = n (n + 2) sum_k r_k^2 / (n - k) over lags 1..lags."""
    e = e - e.mean()
    n = e.size
    c0 = float(np.dot(e, e))
    if c0 == 0.0 or n <= lags + 1:
        return 0.0
    r = np.array([np.dot(e[:-k], e[k:]) / c0 for k in range(1, lags + 1)])
    return float(n * (n + 2) * np.sum(r * r / (n - np.arange(1, lags + 1))))


def _autocorrelation(x: np.ndarray, lags: int) -> np.ndarray:
    c0 = float(np.dot(x, x)) or 1.0
    return np.array([np.dot(x[:x.size - k], x[k:]) / c0 for k in range(lags + 1)])


def cross_correlation_stat(e: np.ndarray, u: np.ndarray, lags: int = LAGS) -> float:
    """sum_{k=0..lags} r_eu(k)^2 / var(r_eu), the input leading the residual: chi^2 with lags + 1 degrees of
    freedom when the residual is independent of the input.  var(r_eu) by Bartlett's formula,
    (1/n) sum_j rho_e(j) rho_u(j): a slow input (every bench input is) against a residual with some colour
    left would otherwise read as correlation (measured: up to 3x the threshold on logs of the true model)."""
    e = e - e.mean()
    u = u - u.mean()
    n = e.size
    den = math.sqrt(float(np.dot(e, e)) * float(np.dot(u, u)))
    if den == 0.0 or n <= 2 * lags + 1:
        return 0.0
    r = np.array([np.dot(e[k:], u[:n - k]) / den for k in range(lags + 1)])
    re, ru = _autocorrelation(e, 2 * lags), _autocorrelation(u, 2 * lags)
    var = max((1.0 + 2.0 * float(np.dot(re[1:], ru[1:]))) / n, 1.0 / n)
    return float(np.sum(r * r) / var)


def correlation_functions(e: np.ndarray, u: np.ndarray, lags: int = LAGS) -> tuple[np.ndarray, np.ndarray, float]:
    """Residual autocorrelation (lags 0..lags), residual-input cross-correlation (lags -lags..lags) and the
    99 % band 2.58/sqrt(n), for the figure drawn as ``resid`` draws it."""
    e = e - e.mean()
    u = u - u.mean()
    n = e.size
    ce = float(np.dot(e, e)) or 1.0
    den = math.sqrt(ce * (float(np.dot(u, u)) or 1.0))
    auto = np.array([np.dot(e[:n - k], e[k:]) / ce for k in range(lags + 1)])
    cross = np.array([(np.dot(e[k:], u[:n - k]) if k >= 0 else np.dot(e[:n + k], u[-k:])) / den
                      for k in range(-lags, lags + 1)])
    return auto, cross, 2.58 / math.sqrt(max(n, 1))


def decimation(dt_s: float) -> int:
    return max(1, int(round(1.0 / (DECIMATED_RATE_HZ * dt_s))))


def model_check(y: np.ndarray, pred: np.ndarray, u: np.ndarray, noise_rad: dict, dt_s: float, scope: str,
                window_s: float = 40.0) -> dict:
    """The adequacy verdict.  ``y``, ``pred``: (n, 2) measured and simulated alpha, beta [rad]; ``u``: (n, 2)
    u1, u2 [V]; ``noise_rad``: the measurement-noise floor per angle; ``scope``: how the simulation was made.
    ``caution`` (or None) is the sentence's closing words about a floor the log cannot measure, kept apart so
    that the caller adds it after its own (identify: which known value the data blame).

    When an angle's noise floor cannot be measured (below SMOOTHED_FLOOR_RAD: smoothed or noise-free angles)
    and the model misses it, the verdict does not rest on that floor alone: a flexible black-box model's
    held-out simulation error (numerics/blackbox.py, in windows of ``window_s`` [s] like eq. (1)'s) is the
    floor the log can measure.  Above RMS_OVER_NOISE of it the model does not fit (measured: a flexible model
    does better); within it the fit is not decided (``adequate`` None): the model simulates the angles as
    well as the black box, and what lies below that the log cannot show.  ``floor_used`` per axis says which."""
    step = decimation(dt_s)
    thr_white = float(chdtri(LAGS, 1.0 - LEVEL))  # chi2 quantile
    thr_cross = float(chdtri(LAGS + 1, 1.0 - LEVEL))
    axes, problems, undecided, bb_all = {}, [], [], None
    for j, ang in enumerate(ANGLES):
        e = y[:, j] - pred[:, j]
        rms = float(np.sqrt(np.mean(e * e)))
        floor = max(noise_rad[ang], 0.0)
        spread = float(np.linalg.norm(y[:, j] - y[:, j].mean()))
        exact = rms < NUMERICAL_FLOOR_RAD
        ratio = rms / max(floor, NUMERICAL_FLOOR_RAD)
        ed = e[::step]
        # the input's mean over each decimated interval: what drove the angle in that time
        ud = [np.add.reduceat(u[:, i], np.arange(0, u.shape[0], step))[:ed.size] / step for i in range(2)]
        white = ljung_box(ed)
        cross = {f"u{i + 1}": cross_correlation_stat(ed, ud[i]) for i in range(2)}
        ok_rms = ratio <= RMS_OVER_NOISE
        applies = floor >= SMOOTHED_FLOOR_RAD and not exact
        ok_cross = max(cross.values()) <= thr_cross if applies else None
        ok_white = white <= thr_white if applies else None
        why_not = None if applies else (
            "the fit is exact to the integrator" if exact else
            f"the angle carries no measurable noise (floor below {SMOOTHED_FLOOR_RAD:g} rad: smoothed, or simulated "
            "without noise), so its residual is coloured whatever the model")
        axes[AXIS_OF[ang]] = {
            "angle": ang,
            "fit_percent": nrmse_fit_percent(y[:, j], pred[:, j]),
            "noise_floor_fit_percent": (100.0 * (1.0 - floor * math.sqrt(y.shape[0]) / spread)
                                        if spread > 0 else math.nan),
            "error_rms_rad": rms, "noise_floor_rad": floor, "rms_over_noise": ratio,
            "rms_over_noise_threshold": RMS_OVER_NOISE,
            "whiteness": {"ljung_box_q": white, "threshold": thr_white, "lags": LAGS, "level": LEVEL,
                          "white": ok_white, "decimated_every": step, "applies": applies, "why_not": why_not},
            "input_correlation": {"statistic": cross, "threshold": thr_cross, "lags": f"0..{LAGS}", "level": LEVEL,
                                  "uncorrelated": ok_cross, "applies": applies, "why_not": why_not},
            "adequate": ok_rms,
            "noise_floor_measured": floor >= SMOOTHED_FLOOR_RAD,
            "floor_used": "noise",
        }
        if not ok_rms and floor < SMOOTHED_FLOOR_RAD and not exact:
            bb_all = _black_box(y, u, dt_s, window_s, bb_all)
            bb = bb_all[ang]
            axes[AXIS_OF[ang]]["black_box"] = bb
            over = rms / bb["rms_rad"] if bb["rms_rad"] else math.inf
            if bb["rms_rad"] is not None and over > RMS_OVER_NOISE:  # a flexible model does measurably better
                axes[AXIS_OF[ang]].update(floor_used="black_box", black_box_ratio=over)
                problems.append(f"the {AXIS_OF[ang]} angle's error is {over:.3g}x what a flexible black-box model "
                                f"leaves on held-out data ({rms:.3g} rad against {bb['rms_rad']:.3g} rad; the angles "
                                "carry no measurable noise, so that is the floor this log can measure)")
            elif bb["rms_rad"] is None or bb["fit_percent"] < MIN_FIT_PERCENT:
                axes[AXIS_OF[ang]].update(floor_used="none", adequate=None)
                undecided.append(f"the {AXIS_OF[ang]} angle's noise floor cannot be measured (its angles carry less "
                                 f"noise than any encoder leaves, below {SMOOTHED_FLOOR_RAD:g} rad) and a flexible "
                                 "black-box model does not simulate it well enough to stand in for it (" +
                                 ("its held-out simulation ran away" if bb["rms_rad"] is None else
                                  f"held-out fit {bb['fit_percent']:.3g} %") + ")")
            else:
                axes[AXIS_OF[ang]].update(floor_used="black_box", black_box_ratio=over, adequate=None)
                undecided.append(f"the {AXIS_OF[ang]} angle is simulated as well as a flexible black-box model "
                                 f"simulates it on held-out data ({rms:.3g} rad against {bb['rms_rad']:.3g} rad), "
                                 "and its noise floor cannot be measured (its angles carry less noise than any "
                                 "encoder leaves): a finer misfit cannot be told on this log")
            continue
        if not ok_rms:
            worst = max(cross, key=cross.get)
            problems.append(f"the {AXIS_OF[ang]} angle's error is {ratio:.3g}x its noise level "
                            f"({rms:.3g} rad against {floor:.3g} rad)" +
                            (f", correlated with {worst}" if ok_cross is False else "") +
                            (", not white" if ok_white is False else ""))
    adequate = False if problems else (None if undecided else True)
    unmeasured = [AXIS_OF[ang] for ang in ANGLES if not axes[AXIS_OF[ang]]["noise_floor_measured"]
                  and axes[AXIS_OF[ang]]["floor_used"] == "noise"]
    fits = ", ".join(f"{a} {v['fit_percent']:.2f} % (noise floor allows {v['noise_floor_fit_percent']:.2f} %)"
                     for a, v in axes.items())
    if adequate and below_integrator(axes):
        sentence = (f"The model fits this log to the integrator's precision (angle errors below "
                    f"{NUMERICAL_FLOOR_RAD:g} rad; the angles carry no measurable noise, so the log is simulated or "
                    f"smoothed): simulation fit {fits}. The intervals measure what is left, the integration's and "
                    "the input hold's error, not a noise: read them as a lower bound.")
    elif adequate:
        sentence = (f"The model fits this log to its noise level: simulation fit {fits}. The intervals are "
                    "trustworthy as far as the model's known values are right.")
    elif adequate is None:
        sentence = ("Not decided: " + "; ".join(undecided) + f" (simulation fit {fits}). The estimates carry no "
                    "adequacy verdict; with the encoder's resolution known, give the log its real noise.")
    else:
        sentence = ("The model does NOT fit this log: " + "; ".join(problems) + f" (simulation fit {fits}). "
                    "The estimates are those of a model that does not fit, and their intervals are conditional "
                    "on it; run `trms-ident diagnose` on the log to find what the model leaves out, and check the "
                    "known values (--params).")
    caution = None
    if unmeasured and adequate is False:
        carry = "angles carry" if len(unmeasured) > 1 else "angle carries"
        caution = (f" Caution: the {' and '.join(unmeasured)} {carry} less noise than any encoder leaves "
                   f"(below {SMOOTHED_FLOOR_RAD:g} rad): the recording smoothed or interpolated the angles, or the "
                   "log is simulated without noise, so the noise floor is a lower bound this log cannot measure "
                   "and the error ratios overstate the misfit; the simulation fit is the measure to read.")
    return {"adequate": adequate, "axes": axes, "simulation": scope, "sentence": sentence, "caution": caution,
            "undecided_because": UNMEASURABLE if adequate is None else None}


def below_integrator(axes: dict) -> bool:
    """Is an axis of model_check's ``axes`` fitted below the integrator's precision (NUMERICAL_FLOOR_RAD) on a log
    whose noise floor cannot be measured: the fit judged against that precision, not a noise floor?"""
    return any(a["error_rms_rad"] < NUMERICAL_FLOOR_RAD and not a["noise_floor_measured"] for a in axes.values())


#: why a verdict is not decided (model_check's ``undecided_because``): the noise floor cannot be measured and the
#: model simulates the angles as well as a black box; or (identify) the output-error fit did not converge
UNMEASURABLE = "the log's noise floor cannot be measured"
NOT_CONVERGED = "the output-error fit did not converge"


def judging_floors(check: dict | None, noise_rad: dict) -> tuple[dict, dict]:
    """The floors a model is fitted and judged against on this log, from the seed model's check (model_check):
    (angle -> floor [rad], angle -> which: "noise", "black_box" or "none").  The measured noise floor where the
    log measures one; where the angles carry no measurable noise and the seed model misses them, the black-box
    model's held-out error that check measured ("black_box": the floor the log can measure, and the weight of
    that angle in an output-error fit: a 1e-9 rad "floor" of a smoothed angle would make the other angle count
    for nothing); "none" where the black box does not simulate the angle either (the noise floor is kept, a
    lower bound: no verdict can rest on it)."""
    floors, used = dict(noise_rad), {}
    for ang in ANGLES:
        ax = ((check or {}).get("axes") or {}).get(AXIS_OF[ang]) or {}
        kind = ax.get("floor_used", "noise")
        bb = (ax.get("black_box") or {}).get("rms_rad")
        if kind == "black_box" and bb:
            floors[ang] = max(float(noise_rad[ang]), float(bb))
        used[ang] = kind
    return floors, used


def _black_box(y: np.ndarray, u: np.ndarray, dt_s: float, window_s: float, known: dict | None) -> dict:
    """The black box's held-out errors (blackbox.achievable_error_rad), computed once for both angles."""
    if known is not None:
        return known
    from .blackbox import achievable_error_rad

    return achievable_error_rad(y, u, dt_s, window_s)
