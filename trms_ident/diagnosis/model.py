"""Filtered regressions of the seed model extended by candidate effects (reference path, scipy filters).

A model = input modifications (dead zone, saturation, delay, motor time constant) applied to
the logged voltages before the plant signals are formed, plus extra linear regressors: torques
per unit parameter phi added to the right-hand side of eq. (1),

    J x'' + B x' = y + sum theta_j phi_j   =>   F[y] = J F[s^2 x] + B F[s x] - sum theta_j F[phi_j]   (eq. 3)
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field, fields

import numpy as np
from scipy import signal

from ..log import Log
from ..model import effects
from ..model.structure import gyroscope_voltage, of_bench, reaction_voltage, stops
from ..numerics.filters import discretize, second_order_lowpass
from ..numerics.fused import plant_signals  # compiled, equal to regressors.plant_signals to round-off
from ..numerics.kernel_args import readonly
from ..numerics.regressors import PlantSignals, filtered_regression

AXIS_ANGLE = {"pitch": "alpha_rad", "yaw": "beta_rad"}


@dataclass(frozen=True)
class Model:
    mods: tuple = ()  # ((candidate key, value), ...) for grid candidates
    linear: tuple = ()  # candidate keys of extra regressors

    def with_mod(self, key: str, value: float) -> "Model":
        return Model(tuple((k, v) for k, v in self.mods if k != key) + ((key, value),), self.linear)

    def moved(self, key: str, value: float) -> "Model":
        """The model with input modification ``key`` (already in it) at ``value``, the order of mods kept."""
        return Model(tuple((k, value if k == key else v) for k, v in self.mods), self.linear)

    def with_linear(self, key: str) -> "Model":
        return Model(self.mods, self.linear + (key,))

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(k for k, _ in self.mods) + self.linear


@dataclass
class Regression:
    """Per axis: target g and design columns (J, B, extra thetas), with column names."""

    g: dict[str, np.ndarray]
    x: dict[str, np.ndarray]
    names: dict[str, list[str]] = field(default_factory=dict)


def settings_of(overrides: dict | None, law: str, **options):
    """identify's Settings for diagnose's bench ``overrides`` (known values by name, the bench's structure under
    model.structure.BENCH_KEY and its given input modifications under model.bench.GIVEN_KEY when it has them), with
    ``options`` (effects, free, ...); the given modifications come first among the effects, ``options``' after."""
    from ..model.bench import GIVEN_KEY
    from ..model.structure import BENCH_KEY
    from ..settings import Settings

    known = dict(overrides or {})
    structure = known.pop(BENCH_KEY, None) or {}
    given = known.pop(GIVEN_KEY, None) or {}
    if given:
        options = {**options, "effects": {**given, **(options.get("effects") or {})}}
    return Settings(thrust_law=law, overrides=known, structure=structure, **options)


def given_model(p: dict | None) -> Model:
    """The model diagnose starts from: the bench's given input modifications (model.bench.given_of), in the bench
    file's order; Model() under eq. (1) alone.  Every fit of the search holds them at their values and the search
    adds its findings to them (the library's candidates they already are are not tried)."""
    from ..model.bench import given_of

    return Model(tuple(given_of(p).items()))


def _low_passed(x: np.ndarray, dt: float) -> np.ndarray:
    """x through the candidates' zero-phase low-pass (second-order Butterworth at min(8 Hz, 0.2 / dt), forwards
    and back: offline, the diagnosis may look ahead); x itself when too short to filter."""
    if x.size <= 12:
        return x
    fc = min(8.0, 0.2 / dt)  # Hz
    b, a = signal.butter(2, fc * 2 * dt)
    return signal.filtfilt(b, a, x)


def smoothed_velocity(x: np.ndarray, dt: float) -> np.ndarray:
    """Zero-phase low-passed central difference [rad/s] (_low_passed)."""
    return _low_passed(np.gradient(x, dt), dt)


def restart_velocity(x: np.ndarray, dt: float, window_s: float = 0.25) -> np.ndarray:
    """Velocity [rad/s] to restart predictions from: local quadratic fits over window_s
    (Savitzky-Golay), less noisy than the low-passed difference at a restart instant."""
    n = int(round(window_s / dt)) | 1
    if x.size <= n or n < 5:
        return smoothed_velocity(x, dt)
    return signal.savgol_filter(x, n, 2, deriv=1, delta=dt)


def observed_log(log: Log, lag_s: float, cache: dict | None = None) -> Log:
    """The log with its angles de-lagged for an acquisition lag of ``lag_s`` [s] (effects.SENSOR_LAG): the exact
    inverse of effects.angle_lag's discrete filter, x_k + K (s_k - s_k-1) with K = c / (1 - c), c = e^(-dt/T),
    taken on s, the angle low-passed zero-phase as the candidates' rates are (smoothed_angle; ``cache`` keeps
    it), so that the angle's noise is not raised K-fold.  (x + T x' with the rate x' left 5 mrad at 200 Hz and 2
    rad/s, T x' with T - dt/2 still 2 mrad at 100 Hz on steps: the filter's second-order term.)"""
    from dataclasses import replace

    cache = cache if cache is not None else {}
    dt = log.sample_time_s
    k = _delag_gain(lag_s, dt)
    out = {}
    for axis, name in AXIS_ANGLE.items():
        key = ("smoothed_angle", axis)
        if key not in cache:
            cache[key] = smoothed_angle(getattr(log, name), dt)
        sm = cache[key]
        x = getattr(log, name)
        d = np.empty_like(sm)
        d[0] = 0.0
        np.subtract(sm[1:], sm[:-1], out=d[1:])
        out[name] = x + k * d
    return replace(log, **out)


def smoothed_angle(x: np.ndarray, dt: float) -> np.ndarray:
    """The angle low-passed zero-phase by smoothed_velocity's filter (_low_passed)."""
    return _low_passed(np.asarray(x, dtype=float), dt)


def _delag_gain(lag_s: float, dt_s: float) -> float:
    """K = c / (1 - c), c = e^(-dt/T): effects.angle_lag's filter inverted is x_k + K (x_k - x_k-1)."""
    c = math.exp(-dt_s / lag_s) if lag_s > 0 else 0.0
    return c / (1.0 - c) if c < 1.0 else 0.0


@functools.lru_cache(maxsize=64)
def delag_noise_gain(dt_s: float, lag_s: float) -> float:
    """How much de-lagging (observed_log) raises white angle noise's RMS: sqrt(sum of the squared impulse
    response of x -> x + K (s_k - s_k-1))."""
    n = 4097
    e = np.zeros(n)
    e[n // 2] = 1.0
    sm = smoothed_angle(e, dt_s)
    h = e.copy()
    h[1:] += _delag_gain(lag_s, dt_s) * (sm[1:] - sm[:-1])
    return float(np.sqrt(np.sum(h * h)))


def modified_inputs(log: Log, mods: dict) -> tuple[np.ndarray, np.ndarray, dict]:
    """Voltages as the plant would see them under the input modifications; parameter changes.

    A voltage no modification touches is the log's own, as a read-only view (no copy: an hour at 1 kHz is
    29 MB a column)."""
    u = {"pitch": readonly(log.u1_v), "yaw": readonly(log.u2_v)}
    changes = {}
    dt = log.sample_time_s
    for key, v in mods.items():
        effect, axis = key.split(":")
        if effect == "input_delay":
            u = {ax: delayed(x, v / dt) for ax, x in u.items()}
        elif effects.declared_modification(key):  # its voltage transform, from the model room (model/effects.py)
            c = effects.by_key(key)
            u[axis] = c.modify(u[axis], v, dt) if c.needs_dt else c.modify(u[axis], v)
        elif effect == "motor_lag":
            changes["T11" if axis == "pitch" else "T21"] = v
    return u["pitch"], u["yaw"], changes


def voltage_drive(log: Log, p: dict, mods: dict) -> np.ndarray | None:
    """u1 as the gyroscope and M_R see it where the bench's structure drives them by the voltage and the main motor
    is second order: through every modification but that motor's further lag, which acts on the motor alone (as
    the output-error kernel drives them, numerics.refine._motor_rhs); None otherwise (they see modified_inputs')."""
    structure = of_bench(p)
    if MAIN_SECOND_LAG not in mods or not (gyroscope_voltage(structure) or reaction_voltage(structure)):
        return None
    return modified_inputs(log, {k: v for k, v in mods.items() if k != MAIN_SECOND_LAG})[0]


MAIN_SECOND_LAG = "motor_second_lag:pitch"


def dead_zone_levels(log: Log, mods: dict, key: str, free: tuple = ()) -> np.ndarray:
    """The distinct |u| > 0 [V], sorted, that the dead zone ``key`` sees on its motor: the log's voltage through
    the modifications of ``mods`` before it, in their order, as the output-error fit applies them (not an
    acquisition lag, nor what the fit integrates itself: model.bench.inside_fit(free)).  A cut dead zone's cost is
    constant between two neighbouring levels (oe.step_interval)."""
    from ..model.bench import MODIFICATION_KEYS, inside_fit

    before = {}
    for k, v in mods.items():
        if k == key:
            break
        if k in MODIFICATION_KEYS and k != effects.SENSOR_LAG and k not in inside_fit(free):
            before[k] = v
    u1, u2 = modified_inputs(log, before)[:2]
    levels = np.unique(np.abs(u1 if key.endswith(":pitch") else u2))
    return levels[levels > 0]


def delayed(u: np.ndarray, samples: float) -> np.ndarray:
    """u(t - d) for a held signal: whole samples shifted, the fraction as the interval's average."""
    m = int(math.floor(samples))
    r = samples - m
    pad = lambda k: np.concatenate([np.full(k, u[0]), u[:u.size - k]]) if k > 0 else u  # noqa: E731
    return (1 - r) * pad(m) + r * pad(m + 1)


#: extra regressors made from the motor states, which the input modifications change
NEEDS_PLANT = ("sensor_offset:pitch", "thrust_asymmetry:pitch", "thrust_asymmetry:yaw")

#: input modifications that change each axis' right-hand side (pitch sees u1 and T11 only; yaw sees
#: u2, T21 and, through the reaction moment M_R, u1 and T11 too)
_PITCH_MODS = ("dead_zone:pitch", "input_saturation:pitch", "input_delay:both", "motor_lag:pitch",
               "com_offset:pitch", "sensor_offset:pitch")


def _pitch_mod(key: str) -> bool:
    """Does modification ``key`` change the pitch axis' right-hand side?"""
    return key in _PITCH_MODS or (effects.declared_modification(key) and key.endswith(":pitch"))


def regression(log: Log, p: dict, law: str, a_rad_s: float, model: Model, cache: dict | None = None) -> Regression:
    """g, design columns per axis; the angle regressors and unchanged targets come from ``cache``.  A model with
    an acquisition lag (effects.SENSOR_LAG) is the same regression of the de-lagged log (observed_log), in a
    cache of its own kept beside ``cache`` for the latest lag value only."""
    cache = cache if cache is not None else {}
    mods = dict(model.mods)
    lag = mods.get(effects.SENSOR_LAG)
    if lag is not None:
        sub_key = ("observed", float(lag))
        sub = cache.get(sub_key)
        if sub is None:
            for k in [k for k in cache if k[0] == "observed"]:  # one lag's columns at a time (memory)
                del cache[k]
            # its targets for the current model only (a lag's columns sit beside the log's own: memory on long logs)
            sub = cache[sub_key] = {("start_states",): cache.get(("start_states",)), ("bytes",): 0}
        rest = Model(tuple((k, v) for k, v in model.mods if k != effects.SENSOR_LAG), model.linear)
        return regression(observed_log(log, lag, cache), p, law, a_rad_s, rest, sub)
    dt = log.sample_time_s
    num, den = second_order_lowpass(a_rad_s, a_rad_s * a_rad_s)
    f = cache.get(("F", a_rad_s))
    if f is None:
        f = cache[("F", a_rad_s)] = discretize(num, den, dt, "bilinear")
    keys = {"pitch": ("g", "pitch", a_rad_s, tuple(sorted((k, v) for k, v in mods.items() if _pitch_mod(k)))),
            "yaw": ("g", "yaw", a_rad_s, tuple(sorted(mods.items())))}
    need_ps = any(keys[ax] not in cache for ax in keys) or any(needs_plant(k) for k in model.linear)
    ps = pp = None
    if need_ps:
        u1, u2, changes = modified_inputs(log, mods)
        pp = {**p, **changes}
        # exact offsets: the encoder's (true angle = logged - delta) and the centre of mass's (gravity only);
        # the angle regressors F s^2[x], F s[x] are blind to a constant offset and stay as logged
        sensor = mods.get("sensor_offset:pitch", 0.0)
        trig = None
        if sensor == 0.0:  # sin and cos of the logged pitch, once per log
            trig = cache.get(("trig",))
            if trig is None:
                trig = cache[("trig",)] = (np.sin(log.alpha_rad), np.cos(log.alpha_rad))
        # the targets alone unless a plant-dependent column or the start basis needs the motor states too
        full = (any(needs_plant(k) for k in model.linear) or
                any(("start", ax, a_rad_s) not in cache for ax in ("pitch", "yaw")))
        ps = plant_signals(u1, u2, log.alpha_rad - sensor, log.beta_rad, dt, pp, law,
                           gravity_offset_rad=mods.get("com_offset:pitch", 0.0), trig=trig,
                           drive_v=voltage_drive(log, p, mods),
                           start=cache.get(("start_states",)),  # the motors mid-run when the log begins
                           rows="all" if full else "targets")
    reg = Regression({}, {}, {})
    for axis in ("pitch", "yaw"):
        x = getattr(log, AXIS_ANGLE[axis])
        mkey = ("m", axis, a_rad_s)
        skey = ("start", axis, a_rad_s)
        if skey not in cache:
            def head_signals(m: int, ps=ps):  # the seed model's signals over the first m samples
                if ps is not None and ps.tau1 is not None and not mods:
                    return PlantSignals(*(getattr(ps, fl.name)[:m] for fl in fields(ps)))
                return plant_signals(log.u1_v[:m], log.u2_v[:m], log.alpha_rad[:m], log.beta_rad[:m], dt, p, law,
                                     start=cache.get(("start_states",)))

            cache[skey] = start_basis(axis, p, law, head_signals, log.alpha_rad, a_rad_s, dt, f)
        basis = cache[skey]
        if mkey not in cache:
            _, jb = filtered_regression(np.zeros_like(x), x, dt, a_rad_s, a_rad_s * a_rad_s)
            deflate(jb[:, 0], basis)
            deflate(jb[:, 1], basis)
            cache[mkey] = jb
        if keys[axis] not in cache:
            cache[keys[axis]] = deflate(f.apply(ps.y_pitch_nm if axis == "pitch" else ps.y_yaw_nm), basis)  # eq. (3)
            _bound(cache, keep=(keys["pitch"], keys["yaw"]))
        m = cache[mkey]
        cols, names = [m[:, 0], m[:, 1]], ["J", "B"]
        for key in model.linear:
            effect, ax = key.split(":")
            if ax != axis and not (effect == "yaw_inertia_pitch" and axis == "pitch"):
                continue
            ck = ("phi", key, axis, a_rad_s)
            if needs_plant(key):  # depends on the input modifications: not cached
                col = deflate(-f.apply(phi(effect, axis, log, pp, ps, cache)), basis)
            elif effect == "yaw_inertia_pitch" and axis == "pitch":  # its centrifugal torque on pitch
                if ck not in cache:
                    cache[ck] = deflate(-f.apply(phi(effect, axis, log, p, None, cache)), basis)
                col = cache[ck]
            elif effect == "yaw_inertia_pitch":  # a derivative: F s[sin^2(alpha) beta'], exact through F s
                if ck not in cache:
                    _, ms = filtered_regression(np.zeros_like(x), phi(effect, axis, log, p, None, cache), dt,
                                                a_rad_s, a_rad_s * a_rad_s)
                    cache[ck] = deflate(-ms[:, 1], basis)
                col = cache[ck]
            elif ck in cache:
                col = cache[ck]
            else:
                col = cache[ck] = deflate(-f.apply(phi(effect, axis, log, p, None, cache)), basis)
                _bound(cache, keep=(keys["pitch"], keys["yaw"], ck))
            cols.append(col)
            names.append(key)
        # no extra column: the cached regressors themselves (read-only use), not a copy per candidate
        reg.g[axis], reg.x[axis], reg.names[axis] = cache[keys[axis]], m if len(cols) == 2 else np.column_stack(cols), names
        keep = _off_stops(log, p, a_rad_s, cache).get(axis)
        if keep is not None:  # the samples at an end stop, and those the filter carries its torque into, weigh 0
            reg.g[axis], reg.x[axis] = reg.g[axis] * keep, reg.x[axis] * keep[:, None]
    return reg


def _off_stops(log: Log, p: dict, a_rad_s: float, cache: dict) -> dict:
    """{axis: (n,) 1.0 off the bench's end stops, 0.0 at them and for the filter's settling after (identify's
    stop_samples, as DREM leaves them out: a stop's contact torque is in no regression)}; {} without stops."""
    structure = of_bench(p)
    if not any(stops(structure, axis) for axis in ("pitch", "yaw")):
        return {}
    key = ("off_stops", a_rad_s)
    if key not in cache:
        from ..identify import stop_samples

        skip = stop_samples(log, structure, a_rad_s, a_rad_s) or {}
        cache[key] = {axis: (~m).astype(float) for axis, m in skip.items()}
    return cache[key]


def start_columns(axis: str, p: dict, law: str, ps, alpha_rad: np.ndarray, a_rad_s: float, dt: float,
                  f) -> list[np.ndarray]:
    """Regressors of the unknown start states (a log that begins mid-run): the filters start in the steady
    state of the first sample, and the motors at the steady state of the first voltage, so the equation
    error carries their initial-condition responses.  Those are linear in the unknown initial states: the
    filter's own modes z^k, k z^k (double pole z of the bilinear F), and the motor-state error c e^k filtered
    by F, through the thrust's slope (linearised) and, on yaw, through the reaction moment's two lags.  They
    are always in the model (never tested as candidates), like the refinement's start states: every target and
    column is deflated by them once (Frisch-Waugh-Lovell, see deflate), so J, B and the candidates' parameters
    are those of the joint fit, and the held-out tests never have to extrapolate a start transient."""
    n = ps.tau1.size
    k = np.arange(n, dtype=float)
    z = (1.0 - a_rad_s * dt / 2.0) / (1.0 + a_rad_s * dt / 2.0)
    with np.errstate(under="ignore"):
        fz = z ** k
        cols = [fz, k * dt * fz]
        e1 = np.exp(-p["T10"] / p["T11"] * dt) ** k  # main-motor mode
        if axis == "pitch":
            slope = 2.0 * p["a1"] * (np.abs(ps.tau1) if law == "signed" else ps.tau1) + p["b1"]
            cols.append(f.apply(slope * e1 * (1.0 - p["Kg"] * ps.dbeta_rad_s * np.cos(alpha_rad))))
        else:
            e2 = np.exp(-p["T20"] / p["T21"] * dt) ** k
            slope = 2.0 * p["a2"] * (np.abs(ps.tau2) if law == "signed" else ps.tau2) + p["b2"]
            cols += [f.apply(slope * e2), f.apply(e1), f.apply(np.exp(-dt / p["Tp"]) ** k)]
    return cols


#: the start columns are built over the leading samples until k^2 r^k, r the slowest of their modes per sample,
#: falls below this: beyond, they are far under the 1e-12 of their peak at which deflation ignores them
START_TAIL = 1e-20


def start_head(p: dict, a_rad_s: float, dt: float, n: int) -> int:
    """How many leading samples can carry the start columns (their modes: F's double pole, the motors' lags)."""
    z = (1.0 - a_rad_s * dt / 2.0) / (1.0 + a_rad_s * dt / 2.0)
    r = max(abs(z), math.exp(-p["T10"] / p["T11"] * dt), math.exp(-p["T20"] / p["T21"] * dt), math.exp(-dt / p["Tp"]))
    if not r < 1.0:
        return n
    rate, target, k = -math.log(r), -math.log(START_TAIL), 1.0
    for _ in range(30):  # k rate - 2 log k = target, by fixed-point iteration from above
        k = (target + 2.0 * math.log(max(k, 1.0))) / rate
    return min(n, int(math.ceil(k)) + 1)


def start_basis(axis: str, p: dict, law: str, head_signals, alpha_rad: np.ndarray, a_rad_s: float, dt: float,
                f) -> tuple[np.ndarray, int]:
    """_leading_basis of the start columns, built over the leading samples only (start_head; doubled while a
    column is still alive at its end): on an hour at 1 kHz the full-length columns and their temporaries were
    the diagnosis' peak memory.  ``head_signals(m)``: the seed model's PlantSignals over the first m samples."""
    n = alpha_rad.size
    head = start_head(p, a_rad_s, dt, n)
    while True:
        q, n0 = _leading_basis(start_columns(axis, p, law, head_signals(head), alpha_rad[:head], a_rad_s, dt, f))
        if n0 < head or head >= n:
            return q, n0
        head = min(2 * head, n)


def _leading_basis(cols: list[np.ndarray]) -> tuple[np.ndarray, int]:
    """Orthonormal basis of the start columns over the leading samples where they are not negligible."""
    s = np.column_stack(cols)
    mag = np.max(np.abs(s), axis=0)
    live = np.abs(s) > 1e-12 * np.where(mag > 0, mag, 1.0)
    n0 = int(np.max(np.flatnonzero(live.any(axis=1)), initial=-1)) + 1
    q, r = np.linalg.qr(s[:n0]) if n0 else (np.zeros((0, s.shape[1])), np.zeros((s.shape[1], s.shape[1])))
    keep = np.abs(np.diag(r)) > 1e-10 * max(float(np.max(np.abs(np.diag(r)), initial=0.0)), 1e-300)
    return q[:, keep], n0


def deflate(col: np.ndarray, basis: tuple[np.ndarray, int] | None) -> np.ndarray:
    """Remove the start columns' span from ``col`` in place (only its leading samples change) and return it
    (unchanged when ``basis`` is None)."""
    if basis is None:
        return col
    q, n0 = basis
    if n0 and q.shape[1]:
        head = col[:n0]
        head -= q @ (q.T @ head)
    return col


#: the filtered targets and extra-regressor columns kept for reuse, in bytes (oldest dropped first): a bound
#: that holds for any log length (an hour at 1 kHz is 29 MB per column)
CACHE_BYTES = 96e6


def drop_search_columns(cache: dict) -> None:
    """After the search: forget the cached filtered targets, extra-regressor columns and sin, cos of the pitch
    (recomputed if regression() is called again; the regressions kept for the findings hold their own
    references).  On four hours at 1 kHz these were five columns of 115 MB at the prediction fits' peak."""
    for k in [k for k in cache if k[0] in ("g", "phi", "trig", "observed", "smoothed_angle")]:
        del cache[k]


def _bound(cache: dict, keep: tuple) -> None:
    """Drop the oldest filtered targets and extra-regressor columns beyond CACHE_BYTES, or the cache's own bound
    under the key ("bytes",) (both recomputable)."""
    targets = [k for k in cache if k[0] in ("g", "phi")]
    total = sum(cache[k].nbytes for k in targets)
    limit = cache.get(("bytes",), CACHE_BYTES)
    for k in targets:  # insertion order: oldest first
        if total <= limit:
            break
        if k not in keep:
            total -= cache.pop(k).nbytes


def state_signals(log: Log, ps, p: dict, cache: dict) -> dict:
    """Measured and reconstructed signals a torque is made of (effects.Candidate.torque, sparse.LIBRARY): angles
    [rad], rates smoothed as the candidates' [rad/s] (and the scale below which a rate's sign is noise), the
    motor states and thrust torques [N m] of ``ps`` (plant_signals with rows="all"), the logged voltages [V]."""
    dt = log.sample_time_s
    vel = {}
    for axis in ("pitch", "yaw"):
        key = ("velocity", axis)
        if key not in cache:
            cache[key] = smoothed_velocity(getattr(log, AXIS_ANGLE[axis]), dt)
        vel[axis] = cache[key]
    scale = {a: max(3.0 * float(np.median(np.abs(np.diff(v)))), 1e-4) for a, v in vel.items()}
    return {"alpha": log.alpha_rad, "beta": log.beta_rad, "dalpha": vel["pitch"], "dbeta": vel["yaw"],
            "scale_alpha": scale["pitch"], "scale_beta": scale["yaw"], "tau1": ps.tau1, "tau2": ps.tau2,
            "M1": ps.M1_nm, "M2": ps.M2_nm, "MR": ps.MR_nm, "u1": log.u1_v, "u2": log.u2_v,
            "gyro_factor": 1.0 - p["Kg"] * vel["yaw"] * np.cos(log.alpha_rad)}


def needs_plant(key: str) -> bool:
    """Is the extra regressor of ``key`` made from the motor states (which the input modifications change)?"""
    return key in NEEDS_PLANT or effects.generic(key)


def phi(effect: str, axis: str, log: Log, p: dict, ps, cache: dict) -> np.ndarray:
    """Torque per unit parameter that the effect adds to the right-hand side of eq. (1) [N m / unit]."""
    if effects.generic(f"{effect}:{axis}"):  # declared by its torque alone (model/effects.py)
        return np.asarray(effects.by_key(f"{effect}:{axis}").torque(state_signals(log, ps, p, cache)), dtype=float)
    dt = log.sample_time_s
    x = getattr(log, AXIS_ANGLE[axis])
    vkey = ("velocity", axis)
    if vkey not in cache:
        cache[vkey] = smoothed_velocity(x, dt)
    w = cache[vkey]
    if effect == "coulomb_friction":
        scale = max(3.0 * float(np.median(np.abs(np.diff(w)))) / dt * dt, 1e-4)  # below this, sign is noise
        return -np.tanh(w / scale)
    if effect == "quadratic_drag":
        return -w * np.abs(w)
    if effect == "cable_stiffness":
        return -x
    if effect == "com_offset":  # -Mg sin(a + d) = -Mg sin a - d Mg cos a
        return -p["Mg"] * np.cos(x)
    if effect == "sensor_offset":  # true angle = logged - d
        # beta' smoothed, not the raw difference inside y: shared noise would pass for explained residual
        bkey = ("velocity", "yaw")
        if bkey not in cache:
            cache[bkey] = smoothed_velocity(log.beta_rad, dt)
        return p["Mg"] * np.cos(x) - p["Kg"] * ps.M1_nm * cache[bkey] * np.sin(x)
    if effect == "thrust_asymmetry":  # (1 + s) M(tau) for tau < 0: s M per unit s, through the gyroscopic term too
        if axis == "yaw":
            return np.where(ps.tau2 < 0, ps.M2_nm, 0.0)
        bkey = ("velocity", "yaw")
        if bkey not in cache:
            cache[bkey] = smoothed_velocity(log.beta_rad, dt)
        return np.where(ps.tau1 < 0, ps.M1_nm, 0.0) * (1.0 - p["Kg"] * cache[bkey] * np.cos(x))
    if effect == "yaw_inertia_pitch":
        bkey = ("velocity", "yaw")
        if bkey not in cache:
            cache[bkey] = smoothed_velocity(log.beta_rad, dt)
        if axis == "pitch":  # Lagrange: J'(alpha) beta'^2 / 2 = -dJ sin(alpha) cos(alpha) beta'^2
            return -np.sin(x) * np.cos(x) * cache[bkey] ** 2
        # yaw: d/dt[(J2 - dJ sin^2 alpha) beta'] = J2 beta'' - dJ d/dt[sin^2(alpha) beta']
        return np.sin(log.alpha_rad) ** 2 * w  # the caller differentiates it with F s
    raise ValueError(f"no regressor for {effect}")
