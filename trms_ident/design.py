"""The next experiment, planned from the model (issue #35, precision objective): references for the lab's closed
loop that keep the bench within its limits and make J1, B1, J2, B2 as precise as they can be.

Three families (numerics only, no I/O).  A multisine per axis: N_FREQUENCIES sines at frequencies that repeat
exactly over the run (multiples of 1 / duration), log-spaced from the lowest that fits twice into the run up to
the axis' band edge, amplitudes falling as 1 / sqrt(f) (as the simulator's multisine) and Schroeder phases (a
low crest factor: the most excitation for a given peak), scaled to a chosen peak [rad] and faded in over RAMP_S.
A square wave per axis (the paper's shape at a chosen level and period; the yaw's in phase with the pitch's, a
quarter period behind or opposite).  For the precision objectives also a pitch square with the yaw following the
pitch rotor's push (Follow: a gain times the yaw's path with its reference held at zero).  The search: a grid over
the two peaks (a Follow's gain) and the two band edges (or the period and the yaw's lag), at SCREEN_HZ at most,
then the best feasible point's peaks (and a square's period) refined; a candidate is judged by simulating the
closed loop (sim/: eq. (1), the
PID of eq. (9) with the lab's gains and voltage limit) noise-free and taking the Cramer-Rao covariance of the
output-error estimate for that run (numerics/fisher.py).  A candidate that breaks a limit (an angle past its
range, too much time at the voltage limit, a reference faster than allowed) is never chosen.

Objectives: "worst" (E-optimal on the relative scale: the largest relative 95 % half-width of J1, B1, J2, B2)
or "d" (D-optimal: the determinant of the relative covariance); with an effect (a torque effect the refinement's
kernel carries, at a given size, present in the simulated bench): the effect parameter's standard error over its
size, so the design is the one under which diagnose's output-error test is most likely to find it.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.stats import norm

from .diagnosis.discriminate import MIN_COST_GAP
from .numerics.adequacy import RMS_OVER_NOISE
from .numerics.fisher import covariance, detection_power, encoder_covariance, precision_of
from .diagnosis.select import FAMILY_ALPHA
from .model import effects as room
from .model.plant import EFFECT_SLOTS
from .numerics.refine import NAMES
from .numerics.stats import Z95

#: sines per axis
N_FREQUENCIES = 8
#: the references fade in over this long [s] (the run starts from rest)
RAMP_S = 2.0
#: band edges tried per axis [Hz] (the highest frequency of its multisine)
BAND_EDGES_HZ = (0.3, 0.8, 2.0)
#: peaks tried per axis: this many, log-spaced from LOWEST_PEAK of the axis' range up to its range
PEAK_STEPS = 6
LOWEST_PEAK = 0.05
#: rounds of the peaks' refinement around the grid's best (each tries each peak times and over REFINE_RATIO)
REFINE_ROUNDS = 3
REFINE_RATIO = 1.15
OBJECTIVES = ("worst", "d")
#: the search's highest rate [Hz]; then (and with encoders, whose rounding the controller reads) this many of the
#: search's best are simulated again at the run's rate, with the encoders, until one keeps the limits.  A candidate
#: is ranked for a log of the run's samples (the information scales with them) and its time at the voltage limit
#: judged with the voltage noise of the run's rate; measured, a square pair for 60 s: 4.70 % at the limit at 100 Hz,
#: 4.64 % at 1 kHz, each half-width 3.17x the 1 kHz one (sqrt(10) = 3.16).  1 kHz had cost 10x per candidate.
SCREEN_HZ = 100.0
#: the design's simulations step at most this long [s] (at most one sample): the simulator's default 0.5 ms is for
#: ground truth; measured at 100 Hz over 60 s, a square and a multisine pair give the same angles to 5 digits and
#: the same half-widths to 4 at 0.5 ms and 10 ms, 0.06 s against 0.006 s a run
MAX_STEP_S = 5e-3
CONFIRMED = 5
#: with encoders, the choice is confirmed with their grids at these fractions of the quantum off zero, the worst
#: kept (measured: a 120 s design at 4.8 % of the time at the voltage limit noise-free read 5.2 % on one grid), and
#: its predicted intervals are averaged over the loop simulated at each (fisher.encoder_covariance)
GRID_OFFSETS = (0.0, 0.25, 0.5, 0.75)
#: processes the search's grid and refinement, and the encoders' grid places, run on (each candidate is simulated
#: and judged on its own, so the answer does not depend on them: the same JSON on one and on two; measured on this
#: 2-core machine, 60 s at 1 kHz: 53 s on one, 34 s on two (44 s on two since the Follow family); 20 s at 100 Hz:
#: 19 s and 15 s; telling the two pitch offsets apart, 60 s at 1 kHz: 125 s and 103 s)
WORKERS = min(2, os.cpu_count() or 1)
#: the effects design can plan for: the torque effects the refinement's kernel carries with exact sensitivities
EFFECTS = tuple(EFFECT_SLOTS)
#: diagnose's family: its candidates and level (diagnosis/select.py), for the predicted power of an effect
FAMILY_TESTS = len(room.CANDIDATES)


@dataclass(frozen=True)
class Limits:
    """What the design must keep: the angles' ranges [rad] (yaw: the cable), the share of samples with a motor
    voltage at the controller's limit, the references' largest rate [rad/s] (None: no limit), and on how far off
    a bench (relative J/B) they must hold too."""

    pitch_rad: float = 1.0
    yaw_rad: float = 3.0
    saturated_share: float = 0.05
    ref_rate_rad_s: float | None = None
    #: the limits must hold on benches whose J/B are this far off the given ones too (off_bench; 0: on the given
    #: bench only, the off-bench run then only said)
    robust_rel: float = 0.0


@dataclass(frozen=True)
class Multisine:
    """One axis' reference: its peak [rad] and band edge [Hz]."""

    peak_rad: float
    band_hz: float
    kind: str = "multisine"


@dataclass(frozen=True)
class Square:
    """One axis' reference: a square wave of this level [rad] and period [s], ``lag_periods`` periods behind the
    run's start (the yaw's: 0 in phase with the pitch, 0.25 a quarter behind, 0.5 opposite), its level faded in
    linearly over ``fade_s`` [s] (0: at full level from the start)."""

    peak_rad: float
    period_s: float
    kind: str = "square"
    lag_periods: float = 0.0
    fade_s: float = 0.0


@dataclass(frozen=True)
class Follow:
    """The yaw's reference: ``gain`` times the path the yaw takes on the given bench when its reference is held at
    zero while the pitch runs its own (followed()).  The pitch rotor's reaction torque pushes the yaw; a yaw
    reference that moves with that push lets the tail rotor spend its voltage on the experiment instead of on
    fighting it (measured, bench C of benchmarks/design.py, 30 s at 1 kHz with 12-bit encoders, a pitch square of
    +-0.55 rad at 2.38 s: with the yaw held at zero 6.2 % of the time at the voltage limit; with the yaw following
    at gain 1, 1.8 % and B1 to +-0.021 %, where the best square pair within 5 % read +-0.035 %)."""

    gain: float
    kind: str = "follow"


#: gains of the yaw's Follow tried (the refinement scales them as it does the peaks)
FOLLOW_GAINS = (0.5, 0.75, 1.0)
#: the pitch square a Follow yaw goes with fades in over this long [s].  At full level from the start the pitch
#: rotor's spin-up pushes the yaw far once (bench C, a +-0.73 rad square at 2.52 s: the followed yaw up to 1.9 rad
#: in the first 5 s, 0.1 rad after 10 s) and that transient held the tail rotor at its limit 20 % of the first
#: 5 s and carried most of J2's information, so estimate's batch-means interval for J2 rested on a block or two
#: (0.45-1.05x the prediction over five seeds); faded in over 5 s the same pair reads 0 % at the limit, the yaw
#: 0.2 rad, and B1 as precise within 10 %, which lets the pitch's level go up instead
FOLLOW_FADE_S = 5.0

#: square-wave periods tried [s]: log-spaced 1-8 s at ratio 2^(1/4).  The worst half-width is B1's on the
#: benches of benchmarks/design.py, and it depends sharply on the period (measured, Table 1's bench, 60 s at 100 Hz,
#: pitch +-0.5 rad, yaw opposite at +-0.3 rad: 5.8 % at 1.5 s, 0.61 % at 2 s, 0.42 % at 2.5 s, 0.15 % at 3 s,
#: 0.60 % at 3.5 s, 0.91 % at 4 s): the closed loop's pitch resonance, where the damping shows most.  Octaves
#: (1, 2, 4, 8 s) missed it; REFINE_PERIOD refines the best between grid points.
PERIODS_S = tuple(float(x) for x in np.round(np.geomspace(1.0, 8.0, 13), 3))
#: the yaw square's lag behind the pitch's [periods]: in phase, a quarter behind, opposite.  Which one keeps the
#: yaw motor off its limit depends on the bench: the pitch rotor's reaction torque pushes the yaw, and a yaw
#: reference that moves with that push asks less of the tail rotor (measured, bench C of benchmarks/design.py, pitch
#: +-0.3 rad and yaw +-0.1 rad at 2 s: 1.8 % of the time at the limit in phase, 7.1 % a quarter behind)
YAW_LAGS = (0.0, 0.25, 0.5)
#: the period's refinement around the best square (each round tries it times and over this)
REFINE_PERIOD = 1.06


@dataclass
class Run:
    """A reference pair simulated in the closed loop: what it would log and how precise J/B would be."""

    t_s: np.ndarray
    alpha_ref_rad: np.ndarray
    beta_ref_rad: np.ndarray
    u1_v: np.ndarray
    u2_v: np.ndarray
    alpha_rad: np.ndarray
    beta_rad: np.ndarray
    precision: dict  # NAMES -> {"se", "half_width", "relative"} (fisher.precision_of); {} when not evaluated
    envelope: dict  # largest |alpha|, |beta| [rad], |u1|, |u2| [V], share of samples at the voltage limit
    violations: list = field(default_factory=list)  # the limits it breaks, in words (empty: feasible)
    score: float = math.inf  # the objective (lower is better; inf when it breaks a limit or cannot be evaluated)
    effect: dict | None = None  # with an effect: {"key", "size", "se", "t" (size / se), "power"}
    #: with --discriminate: discrimination()'s {"truth", "truth_value", "truth_cost", "closest", "rivals": {key:
    #: {"gap", "value", "converged", "rule", "rms_over_noise", "z", "power"}}}
    discrimination: dict | None = None


def frequencies_hz(duration_s: float, band_hz: float, n: int = N_FREQUENCIES) -> np.ndarray:
    """n frequencies [Hz] that repeat over the run, log-spaced from 2 / duration up to ``band_hz`` (distinct
    multiples of 1 / duration; fewer when the band holds fewer)."""
    f0 = 1.0 / duration_s
    lo = 2.0 * f0
    hi = max(band_hz, lo * 2.0)
    k = np.unique(np.round(np.geomspace(lo, hi, n) / f0).astype(int))
    return k[k >= 2] * f0


def multisine(t_s: np.ndarray, duration_s: float, m: Multisine, offset: int = 0) -> np.ndarray:
    """The axis' reference [rad] at ``t_s``: Schroeder-phased sines (``offset`` shifts the phases so the two axes
    differ), scaled so that its largest |value| over t_s is m.peak_rad, faded in over RAMP_S."""
    f = frequencies_hz(duration_s, m.band_hz)
    amp = 1.0 / np.sqrt(f / f[0])
    amp /= np.sqrt(np.sum(amp ** 2))
    k = np.arange(1, f.size + 1) + offset
    phase = -np.pi * k * (k - 1) / f.size  # Schroeder (1970)
    y = np.sin(2 * np.pi * f[:, None] * t_s[None, :] + phase[:, None]).T @ amp
    y *= np.clip(t_s / RAMP_S, 0.0, 1.0)
    top = float(np.max(np.abs(y))) if y.size else 0.0
    return y * (m.peak_rad / top) if top > 0 else y


def square(t_s: np.ndarray, m: Square, lag_periods: float | None = None) -> np.ndarray:
    """The axis' square wave [rad] at ``t_s``: +-m.peak_rad switching every half period, starting at 0 (from rest)
    and ``lag_periods`` (default: m.lag_periods) periods behind."""
    lag_periods = m.lag_periods if lag_periods is None else lag_periods
    y = m.peak_rad * np.sign(np.sin(2 * np.pi * (t_s / m.period_s - lag_periods)))
    y[t_s < lag_periods * m.period_s] = 0.0
    if m.fade_s > 0:
        y *= np.clip(t_s / m.fade_s, 0.0, 1.0)
    return y


def voltage_noise_v(pid: dict, noise_rad: dict, dt_s: float) -> tuple[float, float]:
    """The standard deviation [V] of each axis' voltage that white angle noise ``noise_rad`` ({"alpha", "beta"}
    [rad]) makes through the controller ``pid`` at steps ``dt_s``: its proportional and filtered derivative terms
    (the integral's share is negligible), sum over the impulse response of -Kp n_k + Kd d_k."""
    tf = float(pid["Tf"])
    g, c = 1.0 / (tf + dt_s), tf / (tf + dt_s)
    out = []
    for sd, kp, kd in ((noise_rad.get("alpha", 0.0), pid["Kp1"], pid["Kd1"]),
                       (noise_rad.get("beta", 0.0), pid["Kp2"], pid["Kd2"])):
        gain2 = (kp + kd * g) ** 2 + (kd * g * (1.0 - c)) ** 2 / (1.0 - c * c)
        out.append(float(sd) * math.sqrt(gain2))
    return out[0], out[1]


def saturated_with_noise(u1_v: np.ndarray, u2_v: np.ndarray, u_limit_v: float, sd_v: tuple[float, float]) -> float:
    """The expected share of samples with a voltage at ``u_limit_v`` [V] once the controller adds the voltage noise
    ``sd_v`` (voltage_noise_v, Gaussian) to the noise-free ``u1_v``, ``u2_v``: a sample at the limit without noise
    stays there; else either axis' noisy voltage passes it."""
    free = []
    for u, sd in ((u1_v, sd_v[0]), (u2_v, sd_v[1])):
        a = np.abs(np.asarray(u, dtype=float))
        at = a >= u_limit_v * (1 - 1e-9)
        if sd > 0:
            p = norm.sf((u_limit_v - a) / sd) + norm.sf((u_limit_v + a) / sd)
        else:
            p = np.zeros_like(a)
        free.append(np.where(at, 0.0, 1.0 - p))
    return float(np.mean(1.0 - free[0] * free[1]))


def shaped(t_s: np.ndarray, duration_s: float, m, yaw: bool) -> np.ndarray:
    """The reference [rad] of axis shape ``m`` (Multisine or Square) at ``t_s``."""
    if isinstance(m, Square):
        return square(t_s, m)
    return multisine(t_s, duration_s, m, offset=N_FREQUENCIES if yaw else 0)


def scaled(m, k: float):
    """Axis shape ``m`` (Multisine, Square or Follow) with its peak (a Follow: its gain) times ``k``."""
    if isinstance(m, Follow):
        return replace(m, gain=m.gain * k)
    return replace(m, peak_rad=m.peak_rad * k)


def describe(m) -> str:
    """An axis' reference shape (Multisine, Square or Follow) in words."""
    if isinstance(m, Follow):
        return (f"following the pitch rotor's push: {m.gain:.3g} times the yaw's path with its reference held at "
                "zero")
    if isinstance(m, Square):
        lag = {0.0: "", 0.25: ", a quarter period behind the pitch", 0.5: ", opposite to the pitch"}.get(
            m.lag_periods, f", {m.lag_periods:g} periods behind")
        fade = f", faded in over {m.fade_s:g} s" if m.fade_s > 0 else ""
        return f"square wave +-{m.peak_rad:.3g} rad, period {m.period_s:.3g} s{lag}{fade}"
    return f"multisine, peak {m.peak_rad:.3g} rad, up to {m.band_hz:g} Hz"


@dataclass(frozen=True)
class Hypothesis:
    """One explanation diagnose weighed, at a value: a library effect the refinement's kernel carries
    ("com_offset:pitch", EFFECTS) or a known value of eq. (1) off its table ("known_value:kc")."""

    key: str
    value: float

    @property
    def known_value(self) -> str | None:
        return self.key.split(":", 1)[1] if self.key.startswith("known_value:") else None


def hypothesis_key(text: str) -> str:
    """A diagnosis' name for an explanation as a Hypothesis key: "sensor_offset:pitch" stays, "known_value:kc"
    stays, a bare known value's name ("kc", as its look-alikes are listed) becomes "known_value:kc"; ValueError
    for one design cannot weigh (an input modification, a lag: the output-error refit here carries torque effects
    and known values only)."""
    from .params import KNOWN

    key = text if ":" in text else f"known_value:{text}"
    if key.startswith("known_value:"):
        name = key.split(":", 1)[1]
        if name not in KNOWN:
            raise ValueError(f"{text!r} is not a known value of eq. (1)")
        return key
    if key not in EFFECTS:
        raise ValueError(f"{text!r}: design can tell apart the torque effects {', '.join(EFFECTS)} and known values; "
                         "not this one")
    return key


def _refit(u1, u2, alpha, beta, dt: float, params: dict, law: str, noise_rad: dict, h: Hypothesis, start: float):
    """The model with hypothesis ``h`` fitted by output error to these angles (J/B, h's value, the start states
    free; h's value started at ``start``): refine's Refined and h's fitted value."""
    from .numerics.refine import refine as oe_refine

    theta = {k: float(params[k]) for k in NAMES}
    name = h.known_value
    if name is not None:
        r = oe_refine(u1, u2, alpha, beta, dt, {**params, name: start}, law, theta, noise_rad, free=(name,))
    else:
        r = oe_refine(u1, u2, alpha, beta, dt, params, law, theta, noise_rad, free=(h.key,), effects={h.key: start})
    return r, float(r.freed[name or h.key]["estimate"])


#: the two pitch offsets: diagnose tells them apart by their output-error cost gap (diagnosis/discriminate.py);
#: any other look-alike stops being one when its refit leaves an angle above RMS_OVER_NOISE times its noise floor
#: (known_values.py, diagnosis/weigh.py)
OFFSETS_PAIR = frozenset(("com_offset:pitch", "sensor_offset:pitch"))


def told_apart_chance(gap: float) -> float:
    """The chance that a log whose expected output-error cost gap is ``gap`` shows a gap of at least MIN_COST_GAP
    (the gap diagnose needs to tell the two pitch offsets apart, diagnosis/discriminate.py):
    under white angle noise the observed gap is about normal, mean ``gap``, variance 4 ``gap`` (the noise's
    projection on the two models' difference, counted twice)."""
    return float(norm.cdf(_gap_z(gap)))


def _gap_z(gap: float) -> float:
    return (gap - MIN_COST_GAP) / (2.0 * math.sqrt(gap)) if gap > 0 else -math.inf


def _floor_z(excess: float, n: int) -> float:
    """How many standard deviations a rival's squared angle error over the noise floor's, 1 + ``excess`` (its
    noise-free misfit's mean square over the noise variance), sits above RMS_OVER_NOISE^2 on a log of ``n``
    samples (the mean of n squared standard normals, shifted by the misfit: variance (2 + 4 excess) / n)."""
    return (1.0 + excess - RMS_OVER_NOISE ** 2) / math.sqrt((2.0 + 4.0 * excess) / max(n, 1))


def gap_needed(chance: float = 0.9) -> float:
    """The expected cost gap at which told_apart_chance reaches ``chance``: gap - 2 z sqrt(gap) = MIN_COST_GAP."""
    z = float(norm.isf(1.0 - chance))
    return (z + math.sqrt(z * z + MIN_COST_GAP)) ** 2


def discrimination(u1_v, u2_v, alpha_rad, beta_rad, dt_s: float, params: dict, law: str, noise_rad: dict,
                   truth: Hypothesis, rivals: tuple[str, ...], samples_scale: float = 1.0) -> dict:
    """How far each rival stays from ``truth`` on a run (the T-optimal criterion of Atkinson and Fedorov): the
    run's angles are the bench with ``truth`` (noise-free); the truth and each rival are fitted to them by output
    error with J/B and their own value free.  Per rival: the gap, the noise-weighted squared angle error it leaves
    beyond the truth's (the expected difference of the two fits' costs on a recorded run, twice the log
    likelihood ratio); its angles' predicted error RMS over their noise floors on a recorded run; and, by the
    rule diagnose applies to that pair (``rule``: "cost_gap" for the two pitch offsets, else "noise_floor"),
    ``z`` (standard deviations past diagnose's threshold) and ``power`` (the chance it is told apart).  The
    closest rival is the one with the least z.  ``params`` is the table diagnose was given (J/B the bench's).
    ``samples_scale``: judged for a log with this many times the samples (the gap scales with them)."""
    def start_of(key: str) -> float:
        h = Hypothesis(key, 0.0)
        if h.known_value is not None:
            return float(params[h.known_value])
        if {key, truth.key} == OFFSETS_PAIR:
            return -truth.value  # the two offsets mimic each other at opposite signs (EFFECT_SLOTS' conventions)
        return 0.0

    n = len(u1_v) * samples_scale
    own, _ = _refit(u1_v, u2_v, alpha_rad, beta_rad, dt_s, params, law, noise_rad, truth, truth.value)
    out = {}
    for key in rivals:
        r, value = _refit(u1_v, u2_v, alpha_rad, beta_rad, dt_s, params, law, noise_rad, Hypothesis(key, 0.0),
                          start_of(key))
        gap = max(r.cost - own.cost, 0.0) * samples_scale
        excess = {a: max(r.rms_rad[a] ** 2 - own.rms_rad[a] ** 2, 0.0) / noise_rad[a] ** 2 for a in ("alpha", "beta")}
        rule = "cost_gap" if {key, truth.key} == OFFSETS_PAIR else "noise_floor"
        z = _gap_z(gap) if rule == "cost_gap" else max(_floor_z(e, n) for e in excess.values())
        out[key] = {"gap": gap, "value": value, "converged": bool(r.converged), "rule": rule,
                    "rms_over_noise": {a: math.sqrt(1.0 + e) for a, e in excess.items()}, "z": z,
                    "power": float(norm.cdf(z))}
    closest = min(out, key=lambda k: out[k]["z"])
    return {"truth": truth.key, "truth_value": truth.value, "rivals": out, "closest": closest,
            "truth_cost": float(own.cost)}


def bench_of(params: dict, discriminate) -> dict:
    """The simulated bench's known values: ``params`` with a known-value hypothesis under test in."""
    if discriminate is not None and discriminate[0].known_value is not None:
        return {**params, discriminate[0].known_value: discriminate[0].value}
    return params


def _round_precision(r: "Run", rate_hz: float, params: dict, law: str, noise_rad: dict, pid: dict, u_limit_v: float,
                     quantum_rad: float, effect, discriminate, screen: "_Screen", bench: dict | None = None
                     ) -> np.ndarray:
    """r.precision (in place) as what estimate would report on r's references recorded with encoders of
    ``quantum_rad`` [rad]: the loop simulated with the encoders at each place of their grid (GRID_OFFSETS), then
    fisher.encoder_covariance (returned), the places run on ``screen``'s processes."""
    jobs = [(r.t_s, r.alpha_ref_rad, r.beta_ref_rad, rate_hz, params, law, noise_rad, pid, u_limit_v, quantum_rad,
             g * quantum_rad, effect, discriminate, bench) for g in GRID_OFFSETS]
    cov = np.mean(screen.jobs(_grid_covariance, jobs), axis=0)
    r.precision = precision_of(cov, bench_of(params, discriminate))
    return cov


def _grid_covariance(job: tuple) -> np.ndarray:
    """fisher.encoder_covariance of one run: the references through the loop with the encoders' grid at one place."""
    t_s, a_ref, b_ref, rate_hz, params, law, noise_rad, pid, u_limit_v, quantum_rad, grid_rad, effect, discr, \
        bench = job
    x = _simulated(t_s, a_ref, b_ref, rate_hz, params, law, pid, u_limit_v, effect, discr, quantum_rad, grid_rad,
                   bench)
    u1, u2, a, b, known, fixed = as_estimated(t_s, x.u1_v, x.u2_v, x.true_state[:, 0], x.true_state[:, 2],
                                              bench_of(params, discr), bench)
    return encoder_covariance([(u1, u2, a, b)], 1.0 / rate_hz, known, law, noise_rad, quantum_rad, effect, fixed)


def _shape(key: tuple) -> tuple:
    """A candidate's shape without its peaks: each axis' family and period or band edge, and the yaw's lag."""
    return tuple((type(m).__name__, getattr(m, "period_s", None), getattr(m, "band_hz", None),
                  getattr(m, "lag_periods", None)) for m in key)


def _simulated(t_s: np.ndarray, alpha_ref: np.ndarray, beta_ref: np.ndarray, rate_hz: float, params: dict, law: str,
               pid: dict, u_limit_v: float, effect, discriminate, quantum_rad: float = 0.0, grid_rad: float = 0.0,
               bench: dict | None = None):
    """The simulator's closed loop on the references (the bench with the effect or hypothesis it is planned for,
    and the bench file's effects ``bench``: key -> value), noise-free; with encoders of ``quantum_rad`` [rad]
    whose grid sits ``grid_rad`` off zero."""
    from sim import SimSettings, simulate

    from .model.bench import simulator_specs

    return simulate(SimSettings(ref="file", ref_table=(t_s, alpha_ref, beta_ref), duration_s=float(t_s[-1]),
                                sample_rate_hz=rate_hz, thrust_law=law, u_limit_v=u_limit_v,
                                overrides=dict(bench_of(params, discriminate)), pid=dict(pid),
                                effects=simulator_specs(bench or {}) + _effects_of(effect, discriminate),
                                quantization_rad=quantum_rad,
                                quantization_offset_rad=(grid_rad, grid_rad),
                                max_step_s=min(1.0 / rate_hz, MAX_STEP_S)))


def _objective(cov: np.ndarray, params: dict, objective: str) -> float:
    scale = np.array([abs(float(params[k])) for k in NAMES])
    rel = cov / np.outer(scale, scale)
    if objective == "d":
        sign, logdet = np.linalg.slogdet(rel)
        return float(logdet) if sign > 0 else math.inf
    return float(np.max(Z95 * np.sqrt(np.maximum(np.diag(rel), 0.0))))


def simulate_run(t_s: np.ndarray, alpha_ref: np.ndarray, beta_ref: np.ndarray, rate_hz: float, params: dict,
                 law: str, noise_rad: dict, pid: dict, u_limit_v: float, limits: Limits, objective: str = "worst",
                 effect: tuple[str, float] | None = None, judged_anyway: bool = False,
                 discriminate: tuple[Hypothesis, tuple[str, ...]] | None = None, quantum_rad: float = 0.0,
                 samples_scale: float = 1.0, grid_rad: float = 0.0, noise_dt_s: float | None = None,
                 bench: dict | None = None) -> Run:
    """The references (sampled at ``t_s`` [s], from 0, at ``rate_hz``) run through the closed loop noise-free,
    judged against ``limits`` and scored by ``objective``; ``effect`` = (key, size): the bench has that effect and
    the score is its parameter's standard error over its size.  A run that breaks a limit is never chosen, so its
    information matrix is only evaluated when ``judged_anyway`` (the paper's run, reported beside the design).
    ``discriminate`` = (truth, rivals): the bench has the truth (a Hypothesis), and the score is the closest
    rival's z (discrimination(); larger is better, so the score is its negative).
    ``quantum_rad``: the controller reads encoders of this quantum [rad] (the loop is simulated with them: their
    rounding drives the derivative term; measured: 4.8 % of the time at the voltage limit noise-free, 5.2 % with
    12-bit encoders at 1 kHz), their grid ``grid_rad`` [rad] off zero.  Its angles are then rounded, so such a
    run is judged against the limits only (no information, no score).
    ``samples_scale``: the discrimination is judged for a log with this many times the samples (a screen at a
    lower rate than the run's: white noise, the gap grows with the samples), and so is the objective (the
    information grows with them).  ``noise_dt_s``: the run's sample step [s] when the screen's differs (the
    controller's voltage noise is the run's).  ``bench``: the bench file's effects (key -> value) in the simulated
    bench, and in the model the information is computed under (as_estimated: what estimate --params sees)."""
    known = dict(bench_of(params, discriminate))
    r = _simulated(t_s, alpha_ref, beta_ref, rate_hz, params, law, pid, u_limit_v, effect, discriminate, quantum_rad,
                   grid_rad, bench)
    at_limit = (np.abs(r.u1_v) >= u_limit_v * (1 - 1e-9)) | (np.abs(r.u2_v) >= u_limit_v * (1 - 1e-9))
    dt = 1.0 / rate_hz
    # the angles' noise moves the voltages too (a run simulated with the encoders has its rounding in already)
    sd_v = (0.0, 0.0) if quantum_rad > 0 else voltage_noise_v({**pid_defaults(), **pid}, noise_rad, noise_dt_s or dt)
    env = {"alpha_rad": float(np.max(np.abs(r.alpha_rad))), "beta_rad": float(np.max(np.abs(r.beta_rad))),
           "u1_v": float(np.max(np.abs(r.u1_v))), "u2_v": float(np.max(np.abs(r.u2_v))),
           "saturated_share": saturated_with_noise(r.u1_v, r.u2_v, u_limit_v, sd_v),
           "saturated_share_noise_free": float(np.mean(at_limit)), "voltage_noise_v": list(sd_v)}
    env["ref_rate_rad_s"] = max(float(np.max(np.abs(np.diff(x)))) / dt for x in (alpha_ref, beta_ref))
    bad = []
    if not np.all(np.isfinite(r.alpha_rad)) or not np.all(np.isfinite(r.beta_rad)):
        bad.append("the closed loop diverges")
    else:
        if env["alpha_rad"] > limits.pitch_rad:
            bad.append(f"pitch reaches {env['alpha_rad']:.3g} rad (limit {limits.pitch_rad:g})")
        if env["beta_rad"] > limits.yaw_rad:
            bad.append(f"yaw reaches {env['beta_rad']:.3g} rad (limit {limits.yaw_rad:g})")
        if env["saturated_share"] > limits.saturated_share:
            bad.append(f"a motor voltage is at its {u_limit_v:g} V limit {100 * env['saturated_share']:.3g} % of the "
                       f"time with the angles' noise (limit {100 * limits.saturated_share:g} %)")
    if limits.ref_rate_rad_s is not None and env["ref_rate_rad_s"] > limits.ref_rate_rad_s:
        bad.append(f"the reference moves at {env['ref_rate_rad_s']:.3g} rad/s (limit {limits.ref_rate_rad_s:g})")
    if not bad and limits.robust_rel > 0 and not quantum_rad > 0:  # the same limits on benches off the given one
        off = off_bench(t_s, alpha_ref, beta_ref, rate_hz, params, law, noise_rad, pid, u_limit_v, effect,
                        discriminate, limits.robust_rel, bench)
        env["off_bench"] = off
        bad += [f"on a bench whose J/B are {100 * limits.robust_rel:g} % off, {b}"
                for b in off_bench_breaks(off, limits)]
    precision, score, found, told = {}, math.inf, None, None
    if "the closed loop diverges" not in bad and (not bad or judged_anyway) and not quantum_rad > 0:
        try:
            if discriminate is not None:
                told = discrimination(r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, dt, params, law, noise_rad,
                                      *discriminate, samples_scale=samples_scale)
                if not np.isfinite(told["rivals"][told["closest"]]["gap"]):
                    raise FloatingPointError  # (z is -inf for a rival that mimics the truth exactly: a score)
            u1, u2, a, b, model_known, fixed = as_estimated(r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, known,
                                                            bench)
            cov = covariance(u1, u2, a, b, dt, model_known, law, noise_rad, effect,
                             fixed=fixed) / samples_scale  # (white noise: the information grows with the samples)
            precision = precision_of(cov, known)
            if told is not None:
                score = -told["rivals"][told["closest"]]["z"]
            elif effect is not None:
                se = math.sqrt(max(float(cov[4, 4]), 0.0))
                found = {"key": effect[0], "size": float(effect[1]), "se": se,
                         "t": abs(effect[1]) / se if se > 0 else math.inf,
                         "power": detection_power(effect[1], se, FAMILY_TESTS, FAMILY_ALPHA)}
                score = se / abs(effect[1])
            else:
                score = _objective(cov, params, objective)
            score = score if not bad else math.inf
        except (np.linalg.LinAlgError, FloatingPointError, ValueError):
            bad.append("its information matrix cannot be evaluated")
    return Run(r.t_s, alpha_ref, beta_ref, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, precision, env, bad, score, found,
               told)


def as_estimated(t_s: np.ndarray, u1_v: np.ndarray, u2_v: np.ndarray, alpha_rad: np.ndarray, beta_rad: np.ndarray,
                 params: dict, bench: dict | None) -> tuple:
    """A run as `estimate --params` sees it under the bench file's effects ``bench`` (key -> value): (u1 [V], u2
    [V], alpha [rad], beta [rad], known values, the torque effects held in the model): the voltages through its
    input modifications and a motor time constant in place of T11 or T21 (identify.under_model), the torque effects
    for the output-error model.  Unchanged without effects."""
    if not bench:
        return u1_v, u2_v, alpha_rad, beta_rad, params, {}
    from .identify import under_model
    from .log import Log
    from .model.bench import KERNEL_KEYS, TORQUE_KEYS

    log = Log(np.asarray(t_s, dtype=float), np.asarray(u1_v, dtype=float), np.asarray(u2_v, dtype=float),
              np.asarray(alpha_rad, dtype=float), np.asarray(beta_rad, dtype=float), "design")
    seen, known = under_model(log, params, dict(bench), kernel=True)
    return (seen.u1_v, seen.u2_v, seen.alpha_rad, seen.beta_rad, known,
            {k: float(v) for k, v in bench.items() if k in TORQUE_KEYS + KERNEL_KEYS})


def _effects_of(effect, discriminate) -> list:
    """The simulator's effects for the bench a candidate runs on: the effect designed for, or the hypothesis to
    tell apart when it is an effect (a known value is in bench_of's table instead)."""
    if discriminate is not None and discriminate[0].known_value is None:
        return [dict(zip(("effect", "axis"), discriminate[0].key.split(":")), value=float(discriminate[0].value))]
    return [] if effect is None else [dict(zip(("effect", "axis"), effect[0].split(":")), value=float(effect[1]))]


def keep(tried: dict, key, r: Run) -> None:
    """Add the candidate ``key``'s run to ``tried``, keeping the samples of the CONFIRMED best runs only (the
    confirmation and the answer read no others): the runs of a 120 s design at 1 kHz had held 3-5 GB."""
    tried[key] = r
    full = sorted((k for k in tried if tried[k].u1_v.size), key=lambda k: tried[k].score)
    for k in full[CONFIRMED:]:
        x = tried[k]
        empty = np.empty(0)
        tried[k] = replace(x, t_s=empty, alpha_ref_rad=empty, beta_ref_rad=empty, u1_v=empty, u2_v=empty,
                           alpha_rad=empty, beta_rad=empty)


def pid_defaults() -> dict:
    """The simulator's controller gains (a controller file may give some only)."""
    from sim.simulate import DEFAULT_PID

    return dict(DEFAULT_PID)


#: how far off the bench's J/B the chosen references are tried (relative): the design assumes the bench it is
#: given, and a run that sits near a limit there can pass it on a bench whose J/B differ (measured: a square
#: wave at 4.3 % of the time at the voltage limit read 9-11 % with J/B 5 % off)
OFF_BENCH_REL = 0.05


def off_bench(t_s: np.ndarray, alpha_ref: np.ndarray, beta_ref: np.ndarray, rate_hz: float, params: dict, law: str,
              noise_rad: dict, pid: dict, u_limit_v: float, effect=None, discriminate=None,
              rel: float = OFF_BENCH_REL, bench: dict | None = None) -> dict:
    """What the references do on benches whose J/B are ``rel`` off the given ones, the two ways that move the
    loop most (J1, J2 up with B1, B2 down: a livelier bench; and the reverse): the largest |pitch|, |yaw| [rad]
    and share of samples at the voltage limit (with the angles' noise) of the two."""
    out = {"relative": rel, "alpha_rad": 0.0, "beta_rad": 0.0, "saturated_share": 0.0}
    dt = 1.0 / rate_hz
    sd_v = voltage_noise_v({**pid_defaults(), **pid}, noise_rad, dt)
    for sign in (1.0, -1.0):
        f = 1.0 + sign * rel
        moved = {**params, "J1": params["J1"] * f, "J2": params["J2"] * f, "B1": params["B1"] / f,
                 "B2": params["B2"] / f}
        x = _simulated(t_s, alpha_ref, beta_ref, rate_hz, moved, law, pid, u_limit_v, effect, discriminate,
                       bench=bench)
        out["alpha_rad"] = max(out["alpha_rad"], float(np.max(np.abs(x.alpha_rad))))
        out["beta_rad"] = max(out["beta_rad"], float(np.max(np.abs(x.beta_rad))))
        out["saturated_share"] = max(out["saturated_share"], saturated_with_noise(x.u1_v, x.u2_v, u_limit_v, sd_v))
    return out


def off_bench_breaks(off: dict, limits: Limits) -> list:
    """The limits off_bench's runs break, in words."""
    broken = []
    if off["saturated_share"] > limits.saturated_share:
        broken.append(f"a voltage would be at its limit {100 * off['saturated_share']:.3g} % of the time (limit "
                      f"{100 * limits.saturated_share:g} %)")
    if off["alpha_rad"] > limits.pitch_rad:
        broken.append(f"the pitch would reach {off['alpha_rad']:.3g} rad (limit {limits.pitch_rad:g})")
    if off["beta_rad"] > limits.yaw_rad:
        broken.append(f"the yaw would reach {off['beta_rad']:.3g} rad (limit {limits.yaw_rad:g})")
    return broken


@dataclass
class Design:
    """design()'s answer: the chosen references' run, their multisines, the paper's square reference of the same
    length in the same loop (for comparison), and how many candidates were simulated."""

    run: Run
    pitch: Multisine | Square
    yaw: Multisine | Square | Follow
    square: Run
    candidates: int
    feasible: int


def design(duration_s: float, rate_hz: float, params: dict, law: str, noise_rad: dict, pid: dict,
           u_limit_v: float, limits: Limits, objective: str = "worst", progress=None,
           effect: tuple[str, float] | None = None,
           discriminate: tuple[Hypothesis, tuple[str, ...]] | None = None, quantum_rad: float = 0.0,
           workers: int = WORKERS, bench: dict | None = None) -> Design:
    """References for ``duration_s`` [s] at ``rate_hz`` [Hz] that keep ``limits`` and minimise ``objective``
    (OBJECTIVES) for the bench ``params`` under the PID ``pid`` (the simulator's names Kp1 ... Tf) limited to
    ``u_limit_v`` [V], with the logged angles' noise ``noise_rad``.  Raises ValueError when no candidate keeps the
    limits (the message says what the gentlest one breaks).  ``progress(fraction)`` is called as it goes.
    ``effect`` = (key, size): design to find that effect (EFFECTS) instead, the bench simulated with it.
    ``discriminate`` = (truth, rivals): design to tell the truth (a Hypothesis, in the simulated bench) from the
    rivals (hypothesis keys): the closest rival as far past diagnose's threshold as can be (discrimination()).
    ``quantum_rad``: the encoders' quantum [rad] when the noise is their rounding: the choice must keep the limits
    with the controller reading rounded angles too (its envelope is that run's), and the design's and the square's
    predicted intervals are what estimate would report on the run recorded with them (fisher.encoder_covariance;
    the search ranks by the white-noise bound at q / sqrt(12), one evaluation instead of 32 refinements; for the
    precision objective the most precise of the best CONFIRMED shapes by that prediction is chosen).
    ``bench``: the bench file's effects (key -> value; model/bench.py): every candidate runs on the bench as
    diagnosed, and its information is what estimate --params would have under them (as_estimated)."""
    if effect is not None and discriminate is not None:
        raise ValueError("design for an effect or to tell hypotheses apart, not both")
    if discriminate is not None:
        if not discriminate[1]:
            raise ValueError("nothing to tell apart: no rival hypothesis")
        hypothesis_key(discriminate[0].key)
        discriminate = (discriminate[0], tuple(hypothesis_key(k) for k in discriminate[1]))
    if effect is not None and effect[0] not in EFFECTS:
        raise ValueError(f"effect {effect[0]!r}: design can plan for {', '.join(EFFECTS)}")
    if effect is not None and not effect[1] != 0:
        raise ValueError("the effect's size must not be 0")
    if objective not in OBJECTIVES:
        raise ValueError(f"objective must be one of {OBJECTIVES}, got {objective!r}")
    n = int(round(duration_s * rate_hz)) + 1
    t = np.arange(n) / rate_hz
    say = progress or (lambda f: None)
    # the search runs at SCREEN_HZ at most (each candidate judged for a log with the run's samples: white noise), the
    # choice again at the run's rate
    screen_hz = min(rate_hz, SCREEN_HZ)
    ts = np.arange(int(round(duration_s * screen_hz)) + 1) / screen_hz

    spec = (duration_s, rate_hz, params, law, noise_rad, pid, u_limit_v, limits, objective, effect, discriminate,
            dict(bench or {}))

    peaks_a = np.geomspace(LOWEST_PEAK * limits.pitch_rad, limits.pitch_rad, PEAK_STEPS)
    peaks_b = np.geomspace(LOWEST_PEAK * limits.yaw_rad, limits.yaw_rad, PEAK_STEPS)
    grid = [(Multisine(float(pa), fa), Multisine(float(pb), fb)) for fa in BAND_EDGES_HZ for fb in BAND_EDGES_HZ
            for pa in peaks_a for pb in peaks_b]
    grid += [(Square(float(pa), per), Square(float(pb), per, lag_periods=lag)) for per in PERIODS_S
             if per <= duration_s / 2 for lag in YAW_LAGS for pa in peaks_a for pb in peaks_b]
    if effect is None and discriminate is None:  # (the other objectives' benchmarks ran without; see docs/design.md)
        grid += [(Square(float(pa), per, fade_s=FOLLOW_FADE_S), Follow(g)) for per in PERIODS_S
                 if per <= duration_s / 2 for g in FOLLOW_GAINS for pa in peaks_a]
    total = len(grid) + REFINE_ROUNDS * 6
    tried: dict = {}
    with _Screen(spec, ts, screen_hz, workers) as screen:
        for i, (key, r) in enumerate(zip(grid, screen.map(grid))):
            keep(tried, key, r)
            say((i + 1) / total)
        _refine(tried, grid, screen, duration_s, limits, say, total)
        return _chosen(tried, spec, t, screen, quantum_rad)


def _chosen(tried: dict, spec: tuple, t: np.ndarray, screen: "_Screen", quantum_rad: float) -> Design:
    """design()'s choice from the candidates ``tried`` at the screen's rate: confirmed at the run's rate ``t`` [s]
    (and with the encoders), beside the paper's square."""
    duration_s, rate_hz, params, law, noise_rad, pid, u_limit_v, limits, objective, effect, discriminate, bench = spec
    screen_hz = screen.args[2]
    best = min(tried, key=lambda k: tried[k].score)
    chosen = tried[best]
    ranked = quantum_rad > 0 and effect is None and discriminate is None
    if screen_hz != rate_hz or quantum_rad > 0:  # the choice confirmed at the run's own rate and with the encoders
        order = sorted((k for k in tried if math.isfinite(tried[k].score)), key=lambda k: tried[k].score)
        # with encoders and the precision objective, the choice is what estimate would report on the rounded run,
        # and that ranks candidates differently from the white-noise bound (measured, 30 s at 1 kHz: B1 1.5-2.3x
        # the white bound, by shape): the best of CONFIRMED shapes is confirmed and the most precise one kept
        why, confirmed, shapes = [], [], set()
        for k in order[:(3 if ranked else 1) * CONFIRMED]:
            if ranked and _shape(k) in shapes:
                continue
            refs = _references(spec, *k, t, rate_hz)  # (a Follow's is a simulation: made once, run five times)
            chosen = tried[k] if screen_hz == rate_hz and tried[k].u1_v.size else _judged(spec, *refs, t, rate_hz)
            if math.isfinite(chosen.score) and quantum_rad > 0:  # the controller reads the rounded angles
                reads = [_judged(spec, *refs, t, rate_hz, quantum_rad=quantum_rad, grid_rad=g * quantum_rad)
                         for g in GRID_OFFSETS]  # where the encoders' zero sits on their grid is unknown
                read = max(reads, key=lambda x: (len(x.violations), x.envelope["saturated_share"]))
                if read.violations:
                    chosen.violations, chosen.score = list(read.violations), math.inf
                chosen.envelope = read.envelope
            if not math.isfinite(chosen.score):
                why = chosen.violations
                continue
            if ranked:
                cov = _round_precision(chosen, rate_hz, params, law, noise_rad, pid, u_limit_v, quantum_rad, effect,
                                       discriminate, screen, bench)
                chosen.score = _objective(cov[:4, :4], params, objective)
            confirmed.append((k, chosen))
            shapes.add(_shape(k))
            if len(confirmed) == (CONFIRMED if ranked else 1):
                break
        if not confirmed:
            raise ValueError(f"the {CONFIRMED} best references break the limits at {rate_hz:g} Hz"
                             + (" with the encoders' rounding" if quantum_rad > 0 else "") + ": " + "; ".join(why))
        best, chosen = min(confirmed, key=lambda kc: kc[1].score)
    from sim.references import reference

    sa, sb = reference("square", t)  # the paper's experiment 1
    paper = simulate_run(t, sa, sb, rate_hz, params, law, noise_rad, pid, u_limit_v, limits, objective, effect,
                         judged_anyway=True, discriminate=discriminate, bench=bench)
    if quantum_rad > 0:
        for r in ((paper,) if ranked else (chosen, paper)):
            if r.precision:
                _round_precision(r, rate_hz, params, law, noise_rad, pid, u_limit_v, quantum_rad, effect, discriminate,
                                 screen, bench)
    if "off_bench" not in chosen.envelope:  # (with --robust, simulate_run has it; an encoder run's envelope not)
        chosen.envelope["off_bench"] = off_bench(chosen.t_s, chosen.alpha_ref_rad, chosen.beta_ref_rad, rate_hz,
                                                 params, law, noise_rad, pid, u_limit_v, effect, discriminate,
                                                 limits.robust_rel or OFF_BENCH_REL, bench)
    return Design(chosen, best[0], best[1], paper, len(tried),
                  sum(math.isfinite(v.score) for v in tried.values()))



def _candidate(spec: tuple, a, b, times: np.ndarray, hz: float, **kw) -> Run:
    """The reference pair (a, b) (axis shapes) at ``times`` [s] and ``hz`` [Hz] through simulate_run for the design
    ``spec`` = (duration_s, rate_hz, params, law, noise_rad, pid, u_limit_v, limits, objective, effect,
    discriminate, bench): judged for a log with the run's samples and its voltage noise."""
    return _judged(spec, *_references(spec, a, b, times, hz), times, hz, **kw)


def _references(spec: tuple, a, b, times: np.ndarray, hz: float) -> tuple[np.ndarray, np.ndarray]:
    """The axis shapes (a, b) as reference arrays [rad] at ``times`` (a Follow yaw simulated on ``spec``'s bench)."""
    duration_s, _, params, law, _, pid, u_limit_v, _, _, effect, discriminate, bench = spec
    a_ref = shaped(times, duration_s, a, False)
    if isinstance(b, Follow):
        return a_ref, followed(times, a_ref, hz, b, params, law, pid, u_limit_v, effect, discriminate, bench)
    return a_ref, shaped(times, duration_s, b, True)


def _judged(spec: tuple, a_ref: np.ndarray, b_ref: np.ndarray, times: np.ndarray, hz: float, **kw) -> Run:
    """The references through simulate_run for the design ``spec``, judged for a log with the run's samples."""
    duration_s, rate_hz, params, law, noise_rad, pid, u_limit_v, limits, objective, effect, discriminate, bench = spec
    return simulate_run(times, a_ref, b_ref, hz, params, law, noise_rad, pid, u_limit_v, limits, objective, effect,
                        discriminate=discriminate, samples_scale=rate_hz / hz, noise_dt_s=1.0 / rate_hz, bench=bench,
                        **kw)


def followed(t_s: np.ndarray, alpha_ref: np.ndarray, rate_hz: float, m: Follow, params: dict, law: str, pid: dict,
             u_limit_v: float, effect=None, discriminate=None, bench: dict | None = None) -> np.ndarray:
    """The yaw reference [rad] of ``m`` at ``t_s``: m.gain times the yaw's noise-free path in the closed loop on
    the given bench when the pitch runs ``alpha_ref`` [rad] and the yaw's reference is held at zero (it starts at
    zero, from rest, and moves only as the pitch rotor's reaction torque pushes it)."""
    x = _simulated(t_s, alpha_ref, np.zeros_like(alpha_ref), rate_hz, params, law, pid, u_limit_v, effect,
                   discriminate, bench=bench)
    return m.gain * np.asarray(x.beta_rad, dtype=float)


_WORKER: tuple = ()


def _start_worker(spec: tuple, times: np.ndarray, hz: float) -> None:
    global _WORKER
    _WORKER = (spec, times, hz)


def _screened(key: tuple) -> Run:
    spec, times, hz = _WORKER
    return _candidate(spec, *key, times, hz)


class _Screen:
    """Candidates judged at the screen's rate, on ``workers`` processes when more than one (in order)."""

    def __init__(self, spec: tuple, times: np.ndarray, hz: float, workers: int):
        self.args, self.workers, self.pool = (spec, times, hz), max(int(workers), 1), None

    def __enter__(self):
        if self.workers > 1:
            from concurrent.futures import ProcessPoolExecutor

            self.pool = ProcessPoolExecutor(self.workers, initializer=_start_worker, initargs=self.args)
        return self

    def __exit__(self, *exc) -> None:
        if self.pool is not None:
            self.pool.shutdown(cancel_futures=True)

    def jobs(self, fn, jobs: list) -> list:
        """fn (a module-level function) on each of ``jobs``, on the processes when there are more than one."""
        return [fn(j) for j in jobs] if self.pool is None else list(self.pool.map(fn, jobs))

    def map(self, keys: list):
        if self.pool is None:
            spec, times, hz = self.args
            return (_candidate(spec, *k, times, hz) for k in keys)
        return self.pool.map(_screened, keys, chunksize=max(1, min(16, len(keys) // (4 * self.workers))))


def _refine(tried: dict, grid: list, screen: _Screen, duration_s: float, limits: Limits, say, total: int) -> None:
    """After the grid: raise when nothing keeps the limits, else refine the best's peaks (never past the axis'
    range: a reference the bench must not reach) and a square's period."""
    best = min(tried, key=lambda k: tried[k].score)
    if not math.isfinite(tried[best].score):
        gentlest = tried[grid[0]]
        raise ValueError("no reference of the family keeps the limits; the gentlest (peaks "
                         f"{grid[0][0].peak_rad:.3g} and {grid[0][1].peak_rad:.3g} rad) breaks them: "
                         + "; ".join(gentlest.violations or ["its information matrix cannot be evaluated"]))
    for r in range(REFINE_ROUNDS):  # the peaks around the best: limits bind between grid points
        a, b = best
        cands = [(scaled(a, REFINE_RATIO), b), (scaled(a, 1 / REFINE_RATIO), b), (a, scaled(b, REFINE_RATIO)),
                 (a, scaled(b, 1 / REFINE_RATIO))]
        if isinstance(a, Square):  # and the period: the precision peaks sharply at the loop's resonance
            cands += [(replace(a, period_s=a.period_s * k),
                       replace(b, period_s=b.period_s * k) if isinstance(b, Square) else b)
                      for k in (REFINE_PERIOD, 1 / REFINE_PERIOD) if a.period_s * k <= duration_s / 2]
        within = lambda c: (c[0].peak_rad <= limits.pitch_rad * (1 + 1e-12)  # noqa: E731
                            and getattr(c[1], "peak_rad", 0.0) <= limits.yaw_rad * (1 + 1e-12))
        new = list(dict.fromkeys(c for c in cands if c not in tried and within(c)))
        for cand, run in zip(new, screen.map(new)):
            keep(tried, cand, run)
        best = min(tried, key=lambda k: tried[k].score)
        say((len(grid) + 6 * (r + 1)) / total)


#: the controller file's gains (the simulator's names, PID per axis with the derivative through 1/(Tf s + 1))
GAINS = ("Kp1", "Ki1", "Kd1", "Kp2", "Ki2", "Kd2", "Tf")


def controller_from(table: dict, source: str) -> tuple[dict, float]:
    """(the PID gains, the voltage limit [V]) from a TOML file's ``[controller]`` table (already parsed); ValueError
    naming ``source`` and what is missing or wrong."""
    c = table.get("controller")
    if not isinstance(c, dict):
        raise ValueError(f"{source}: no [controller] table; expected one with {', '.join(GAINS)} and u_limit [V]")
    missing = [k for k in (*GAINS, "u_limit") if k not in c]
    if missing:
        raise ValueError(f"{source}: [controller] lacks {', '.join(missing)}; expected {', '.join(GAINS)} and "
                         "u_limit [V]")
    unknown = sorted(set(c) - {*GAINS, "u_limit"})
    if unknown:
        raise ValueError(f"{source}: [controller] has {', '.join(unknown)}, which is not one of {', '.join(GAINS)}, "
                         "u_limit")
    for k in (*GAINS, "u_limit"):
        v = c[k]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
            raise ValueError(f"{source}: [controller] {k} = {v!r}; expected a number >= 0")
    if not c["u_limit"] > 0 or not c["Tf"] > 0:
        raise ValueError(f"{source}: [controller] u_limit and Tf must be > 0")
    return {k: float(c[k]) for k in GAINS}, float(c["u_limit"])
