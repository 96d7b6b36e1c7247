"""A validated TRMS recording: t [s], u1, u2 [V], alpha, beta [rad].

Stamps may jitter (up to JITTER_TOLERANCE of the median step) and a few samples may be missing
(steps up to MAX_GAP_STEPS median steps): the voltages are held over each actual interval
downstream.  A longer gap (a logger that lost rows or paused) splits the log into parts, as runs
joined end to end do: JoinedRunsError carries each part as a Log, for a joint estimate.  The
measured jitter is in ``Log.meta["sampling"]``; units that were told from the values rather than
given (stamps in ms, angles in degrees) are in ``Log.meta["assumed"]``.

Validation is pure (arrays in, LogFormatError out); readers of each file format pass a
``locate`` function that names the file's own row ("line 57"); messages add the time in seconds.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from .errors import JoinedRunsError, LogFormatError

COLUMNS = ("t", "u1", "u2", "alpha", "beta")
#: optional column: when the row's voltages took effect (same unit as t)
VOLTAGE_TIME = "t_u"
COLUMN_UNITS = {"t": "s", "u1": "V", "u2": "V", "alpha": "rad", "beta": "rad"}
MIN_SAMPLES = 10
#: steps within this relative deviation of the median step are jitter, accepted and measured
JITTER_TOLERANCE = 0.25
#: longer steps up to this many median steps are dropped samples (two even at full jitter; counted); longer: a gap, refused
MAX_GAP_STEPS = 4.0
#: steps all within this relative deviation of their mean are uniform to the stamps' own rounding
UNIFORM_TOLERANCE = 2e-3
#: median steps that tell the unit of the stamps: a TRMS log is sampled at 10 Hz to 5 kHz
TIME_UNIT_BY_STEP = ((0.15, "s", 1.0), (150.0, "ms", 1e-3), (math.inf, "us", 1e-6))
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
ANGLE_UNITS = ("auto", "rad", "deg")
#: what Log.meta["units"] says of the angles, by the angle unit the reader was given
ANGLE_UNIT_SAID = {"auto": "rad (no unit given: read as radians, and checked to lie within the bench's range)",
                   "rad": "rad (as given)", "deg": "deg (as given), converted to rad"}
#: the inputs' unit is not in any log format read here (a CSV units row may only say V)
INPUTS_ASSUMED = ("V (assumed: eq. (1) takes volts and the log does not say; inputs in another unit, such as a "
                  "bench's normalised machine units, make the known values wrong and bias every estimate)")
#: |alpha| beyond this is not a pitch angle in rad (the beam stops well before vertical)
PITCH_LIMIT_RAD = math.pi / 2
#: |beta| beyond this (four turns) is not a yaw angle in rad on a cabled bench
YAW_LIMIT_RAD = 8 * math.pi
#: |alpha| up to this is a pitch angle in degrees (the beam's stops lie within +-90 deg; a CE150's elevation
#: reaches 90.1 deg); beyond it the angles are in neither unit
PITCH_LIMIT_DEG = 180.0


@dataclass(frozen=True)
class Log:
    t_s: np.ndarray
    u1_v: np.ndarray
    u2_v: np.ndarray
    alpha_rad: np.ndarray
    beta_rad: np.ndarray
    source: str = "<memory>"
    sha256: str | None = None
    meta: dict = field(default_factory=dict)
    #: (n, 2) times [s] at which u1[k], u2[k] take effect, in [t_k, t_k+1) (the voltage topic's own stamps,
    #: e.g. a controller that publishes just after reading the angles); None: at t_k, held until t_k+1
    u_switch_s: np.ndarray | None = None

    @property
    def sample_time_s(self) -> float:
        """Mean sample interval [s] (the nominal step of a jittered log)."""
        return float((self.t_s[-1] - self.t_s[0]) / (self.t_s.size - 1))

    @property
    def uniform(self) -> bool:
        """True when every step equals the mean step to the stamps' rounding (UNIFORM_TOLERANCE)."""
        return bool(self.meta.get("sampling", {}).get("uniform", True))

    @property
    def held_at_stamps(self) -> bool:
        """True when every voltage takes effect at its own sample's stamp on a uniform grid (the simple case)."""
        return self.uniform and self.u_switch_s is None

    def switch_offsets_s(self) -> np.ndarray:
        """(n, 2) delay [s] from each sample's stamp to the moment its voltages take effect (0: at the stamp)."""
        if self.u_switch_s is None:
            return np.zeros((self.t_s.size, 2))
        return self.u_switch_s - self.t_s[:, None]

    @property
    def duration_s(self) -> float:
        return float(self.t_s[-1] - self.t_s[0])

    def __len__(self) -> int:
        return int(self.t_s.size)

    def head(self, n: int) -> "Log":
        """The log's first n samples (views, no copies); the log itself when it is no longer."""
        return self.span(0, n)

    def span(self, i0: int, i1: int) -> "Log":
        """Samples i0 to i1 - 1 (views, no copies); the log itself when that is all of it."""
        if i0 <= 0 and i1 >= len(self):
            return self
        k = slice(i0, i1)
        return replace(self, t_s=self.t_s[k], u1_v=self.u1_v[k], u2_v=self.u2_v[k], alpha_rad=self.alpha_rad[k],
                       beta_rad=self.beta_rad[k], u_switch_s=None if self.u_switch_s is None else self.u_switch_s[k])


#: steps taken at a time by _step_statistics, and the distinct step values it counts before it falls back
#: to sorting all steps for their median (jittered stamps: every step differs)
STEP_CHUNK = 1 << 17
MAX_DISTINCT_STEPS = 4096


#: a join of two runs: time going back by more than this many median steps (a restart; less is a stamp error)
RESTART_STEPS = 10.0
#: ... or an angle moving farther in one sample than this and than JUMP_RATE_RAD_S x the step (no bench turns
#: 25 rad/s, and a run's angles are continuous)
JUMP_RAD = 0.5
JUMP_RATE_RAD_S = 25.0
#: a jump this close to whole turns is an angle wrapped by its logger (into +-pi), not a join
WRAP_TOLERANCE_RAD = 0.3


def _joins(t: np.ndarray, alpha: np.ndarray, beta: np.ndarray, step: float) -> list[tuple[int, str]]:
    """Where the log breaks into parts: runs joined end to end, or a gap in the stamps longer than MAX_GAP_STEPS
    steps (samples lost); (sample index, why), a chunk at a time (no array the size of the log); ``t`` and the
    median ``step`` in seconds.  A gap's why starts with "a gap"."""
    jump = max(JUMP_RAD, JUMP_RATE_RAD_S * step)
    out = {}
    for i in range(0, t.size - 1, STEP_CHUNK):
        sl = slice(i, i + STEP_CHUNK + 1)
        dt = np.diff(t[sl])
        for k in np.flatnonzero(dt < -RESTART_STEPS * step):
            out.setdefault(i + int(k) + 1, "time restarts")
        for k in np.flatnonzero(dt > MAX_GAP_STEPS * step):
            out.setdefault(i + int(k) + 1, f"a gap of {dt[k]:.6g} s after t = {t[i + k]:.9g} s")
        for name, x in (("alpha", alpha), ("beta", beta)):
            d = np.diff(x[sl])
            turns = np.round(d / (2 * math.pi))
            wrap = (turns != 0) & (np.abs(d - 2 * math.pi * turns) < WRAP_TOLERANCE_RAD)  # a logger's wrap
            for k in np.flatnonzero((np.abs(d) > jump) & ~wrap):
                out.setdefault(i + int(k) + 1, f"{name} jumps {d[k]:+.3g} rad in one sample")
    return sorted(out.items())


def _step_statistics(t: np.ndarray, mean: float) -> tuple[float, float, int | None, float, float]:
    """(min, max, the first sample whose step is not positive or None, RMS about ``mean``, median) of the steps
    np.diff(t), a chunk at a time: no array the size of the log (29 MB an hour at 1 kHz), and exact.  The median
    comes from counts of the distinct step values (a log whose stamps are rounded has a few dozen), or from all
    the steps when they are too many to count."""
    lo, hi, back, acc, counts = math.inf, -math.inf, None, 0.0, {}
    for i in range(0, t.size - 1, STEP_CHUNK):
        d = np.diff(t[i:i + STEP_CHUNK + 1])
        dmin = float(d.min())
        lo, hi = min(lo, dmin), max(hi, float(d.max()))
        if back is None and dmin <= 0:
            back = i + int(np.flatnonzero(d <= 0)[0]) + 1
        e = d - mean
        acc += float(np.dot(e, e))
        if counts is not None:
            values, k = np.unique(d, return_counts=True)
            for v, c in zip(values.tolist(), k.tolist()):
                counts[v] = counts.get(v, 0) + c
            if len(counts) > MAX_DISTINCT_STEPS:
                counts = None
    steps = t.size - 1
    if counts is None:
        median = float(np.median(np.diff(t)))
    else:  # numpy.median's value: the middle one, or the mean of the two middle ones
        keys, seen, middle = sorted(counts), 0, []
        for v in keys:
            seen += counts[v]
            while len(middle) < 2 and seen > ((steps - 1) // 2 if not middle else steps // 2):
                middle.append(v)
            if len(middle) == 2:
                break
        median = (middle[0] + middle[1]) / 2 if middle[0] != middle[1] else middle[0]
    return lo, hi, back, math.sqrt(acc / steps), median


def _default_locate(i: int) -> str:
    return f"sample {i}"


def _placed(locate: Callable[[int], str], t: np.ndarray) -> Callable[[int], str]:
    """``locate``'s row with its time in seconds, ``t`` in seconds: "line 57 (t = 0.056 s)", and how far into
    the log when its clock does not start at 0 ("line 57 (t = 30.056 s, 0.056 s from the start)")."""
    t0 = float(t[0])

    def where(i: int) -> str:
        into = "" if t0 == 0.0 else f", {t[i] - t0:.6g} s from the start"
        return f"{locate(i)} (t = {t[i]:.6g} s{into})"

    return where


def _peak(a: np.ndarray) -> int:
    """The index of a's largest magnitude."""
    return max(int(np.argmax(a)), int(np.argmin(a)), key=lambda j: abs(a[j]))


def angle_unit_of(alpha: np.ndarray, beta: np.ndarray) -> tuple[str | None, str]:
    """The unit of angles logged without one, told from their values: ("rad", "") when both lie within the
    bench's range in radians; ("deg", why) when the pitch cannot be radians (beyond +-pi/2) and lies within its
    range in degrees, the only reading left (the yaw then may turn any number of times: beyond four turns it
    drifted, in either unit, and the reason says so); (None, why) when the pitch is in neither range, or when
    both readings are possible (a yaw beyond four turns in radians beside a pitch within +-pi/2: degrees, or a
    yaw that drifted)."""
    ia, ib = _peak(alpha), _peak(beta)
    a, b = abs(float(alpha[ia])), abs(float(beta[ib]))
    if a <= PITCH_LIMIT_RAD and b <= YAW_LIMIT_RAD:
        return "rad", ""
    if PITCH_LIMIT_RAD < a <= PITCH_LIMIT_DEG:
        turns = math.radians(b) / (2 * math.pi)
        return "deg", (f"alpha reaches {alpha[ia]:.6g}, beyond the pitch's +-{PITCH_LIMIT_RAD:.3g} rad and within "
                       f"its +-{PITCH_LIMIT_DEG:g} deg" + (f"; the yaw turns {turns:.3g} times, a drift"
                                                           if math.radians(b) > YAW_LIMIT_RAD else ""))
    if a > PITCH_LIMIT_RAD:
        return None, (f"alpha reaches {alpha[ia]:.6g}, beyond the pitch's +-{PITCH_LIMIT_RAD:.3g} rad and its "
                      f"+-{PITCH_LIMIT_DEG:g} deg")
    return None, (f"beta reaches {beta[ib]:.6g}, beyond {YAW_LIMIT_RAD:.3g} rad (four turns), while alpha stays "
                  f"within +-{PITCH_LIMIT_RAD:.3g}: degrees, or a yaw that drifted")


def validated(t, u1, u2, alpha, beta, *, source: str = "<memory>", sha256: str | None = None,
              locate: Callable[[int], str] | None = None, meta: dict | None = None,
              angle_unit: str = "auto", time_unit: str = "auto", u_switch_s: np.ndarray | None = None) -> Log:
    """Check a recording and return it as a Log; a problem raises LogFormatError (JoinedRunsError where the
    log breaks into parts: runs joined end to end, or gaps in its stamps).

    ``locate(i)`` names sample i's row for messages (e.g. "line 57"); the messages add its time in seconds.
    ``angle_unit``: "auto" tells the unit from the values (angle_unit_of: radians unless they can only be
    degrees, which are converted and said); "rad" or "deg" (the reader has converted them) says the unit was
    given, and no guess is made.  ``time_unit``: "s", "ms" or "us" scales the stamps; "auto" tells the unit
    from the median step (TIME_UNIT_BY_STEP) and records the assumption.
    """
    arrays = {name: np.ascontiguousarray(v, dtype=float) for name, v in zip(COLUMNS, (t, u1, u2, alpha, beta))}
    meta = dict(meta or {})
    assumed = dict(meta.pop("assumed", {}))
    n = arrays["t"].size
    t = arrays["t"]
    row = locate or _default_locate
    if angle_unit not in ANGLE_UNITS:
        raise LogFormatError(f"{source}: angle unit {angle_unit!r}; expected one of {', '.join(ANGLE_UNITS)}")
    if any(a.shape != (n,) for a in arrays.values()):
        raise LogFormatError(f"{source}: columns have different lengths; expected one value per column per row")
    if n < MIN_SAMPLES:
        raise LogFormatError(f"{source}: only {n} samples; expected at least {MIN_SAMPLES}")
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise LogFormatError(f"{source}: {row(int(bad[0]))}: t is {t[bad[0]]}; expected a finite number in s")
    mean = float((t[-1] - t[0]) / (n - 1))
    lo, hi, back, spread, step = _step_statistics(t, mean)
    if time_unit == "auto":
        unit, factor = next((u, f) for limit, u, f in TIME_UNIT_BY_STEP if step <= limit)
        if unit != "s":
            assumed["time_unit"] = (f"stamps read as {unit} (median step {step:.6g}); pass --time-unit s if they "
                                    "are seconds")
    elif time_unit in TIME_UNITS:
        unit, factor = time_unit, TIME_UNITS[time_unit]
    else:
        raise LogFormatError(f"{source}: time unit {time_unit!r}; expected auto, {', '.join(TIME_UNITS)}")
    if factor != 1.0:
        t = arrays["t"] = t * factor
        u_switch_s = None if u_switch_s is None else np.asarray(u_switch_s, dtype=float) * factor
        lo, hi, mean, spread, step = (v * factor for v in (lo, hi, mean, spread, step))
    where = _placed(row, t)  # every message from here on names the time in seconds
    for name, a in ((k, arrays[k]) for k in COLUMNS[1:]):  # t is finite (checked above)
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise LogFormatError(f"{source}: {where(int(bad[0]))}: {name} is {a[bad[0]]}; "
                                 f"expected a finite number in {COLUMN_UNITS[name]}")
    if angle_unit == "auto":
        told, why = angle_unit_of(arrays["alpha"], arrays["beta"])
        if told is None:
            raise LogFormatError(f"{source}: the angles are in no unit this tool can tell: {why}; expected radians "
                                 "(pass --angle-unit deg to convert degrees, or --angle-unit rad if they are "
                                 "radians)")
        if told == "deg":
            arrays["alpha"], arrays["beta"] = np.radians(arrays["alpha"]), np.radians(arrays["beta"])
            assumed["angle_unit"] = (f"angles read as degrees and converted to rad ({why}); pass --angle-unit rad "
                                     "if they are radians")
            meta["units"] = {"angles": f"deg (told from the values: {why}), converted to rad",
                             **meta.get("units", {})}
            angle_unit = "deg"
    joins = _joins(t, arrays["alpha"], arrays["beta"], step)
    if joins:
        edges = [0, *[i for i, _ in joins], n]
        gaps_only = all(why.startswith("a gap") for _, why in joins)
        part = "part" if gaps_only else "run"
        units = {"angles": ANGLE_UNIT_SAID[angle_unit], **meta.get("units", {})}  # the angles are checked: as said
        runs = [validated(arrays["t"][a:b], arrays["u1"][a:b], arrays["u2"][a:b], arrays["alpha"][a:b],
                          arrays["beta"][a:b], source=f"{source} {part} {k + 1}",
                          locate=(lambda i, a=a: row(i + a)), meta=dict(meta, assumed=assumed, units=units),
                          angle_unit="rad", time_unit="s",
                          u_switch_s=None if u_switch_s is None else np.asarray(u_switch_s)[a:b])
                for k, (a, b) in enumerate(zip(edges[:-1], edges[1:]))]
        said = "; ".join(f"{where(i)}: {why}" for i, why in joins)
        gaps = [{"after_s": float(t[i - 1]), "length_s": float(t[i] - t[i - 1]), "where": where(i)}
                for i, why in joins if why.startswith("a gap")]
        if gaps_only:
            found = f"{source}: {said}" if len(joins) == 1 else f"{source}: {len(joins)} gaps in its stamps ({said})"
            expected = (f"expected steps of {step:.6g} s with at most ±{JITTER_TOLERANCE:.0%} jitter (or up to "
                        f"{MAX_GAP_STEPS:g} steps where samples were dropped): estimate the {len(runs)} parts "
                        "jointly (trms-ident estimate does, unless --strict-gaps), or split the log there")
        else:
            found = f"{source}: holds {len(runs)} runs joined end to end ({said})"
            expected = "expected one run: estimate them as runs of one bench with --joint, or split the file"
        raise JoinedRunsError(found, runs, expected=expected, gaps=gaps)
    if back is not None:
        i = back
        what = "repeats the previous time" if t[i] == t[i - 1] else "goes back in time"
        raise LogFormatError(f"{source}: {where(i)}: t = {t[i]:.9g} s {what} (t = {t[i - 1]:.9g} s); "
                             "expected strictly increasing time")
    if lo < step * (1.0 - JITTER_TOLERANCE):  # a step too short for jitter (a gap too long is a join, above)
        dt = np.diff(t)
        i = int(np.flatnonzero(dt / step < 1.0 - JITTER_TOLERANCE)[0]) + 1
        raise LogFormatError(
            f"{source}: {where(i)}: a step of {dt[i - 1]:.6g} s after t = {t[i - 1]:.9g} s; expected steps of "
            f"{step:.6g} s with at most ±{JITTER_TOLERANCE:.0%} jitter")
    if hi > step * (1.0 + JITTER_TOLERANCE):  # dropped samples: counted, and left out of the jitter figure
        rel = np.diff(t) / step
        dropped = rel > 1.0 + JITTER_TOLERANCE
        kept = rel[~dropped]
        jitter = float(100.0 * np.std(kept)) if kept.size else 0.0
        n_dropped = int(np.sum(np.round(rel[dropped]) - 1))
        del rel, kept
    else:
        jitter, n_dropped = float(100.0 * spread / step), 0
    meta["sampling"] = {
        "uniform": bool(hi - mean <= UNIFORM_TOLERANCE * mean and mean - lo <= UNIFORM_TOLERANCE * mean),
        "median_step_s": step, "min_step_over_median": lo / step, "max_step_over_median": hi / step,
        "jitter_rms_percent": jitter, "dropped_samples": n_dropped, "time_unit": unit}
    meta["units"] = {"angles": ANGLE_UNIT_SAID[angle_unit], **meta.get("units", {})}
    meta["units"].setdefault("inputs", INPUTS_ASSUMED)
    if assumed:
        meta["assumed"] = assumed
    if u_switch_s is not None:
        u_switch_s = np.ascontiguousarray(u_switch_s, dtype=float).reshape(n, 2)
        nxt = np.append(t[1:], np.inf)[:, None]
        bad = np.flatnonzero(np.any((u_switch_s < t[:, None]) | (u_switch_s >= nxt) | ~np.isfinite(u_switch_s), axis=1))
        if bad.size:
            i = int(bad[0])
            raise LogFormatError(f"{source}: {where(i)}: a voltage takes effect at {u_switch_s[i].tolist()} s, outside "
                                 f"its sample interval [{t[i]:.9g}, {nxt[i, 0]:.9g}) s; expected one switch per interval")
        if not np.any(u_switch_s > t[:, None]):
            u_switch_s = None  # every voltage at its own stamp: the simple case
    return Log(*arrays.values(), source=source, sha256=sha256, meta=meta, u_switch_s=u_switch_s)
