"""Where the nominal model's equation error is large: in time, by operating regime, by lag."""
from __future__ import annotations

import numpy as np


def segments(t: np.ndarray, r: np.ndarray, window_s: float, context: dict[str, np.ndarray],
             limit: float = 2.0, most: int = 5) -> list[dict]:
    """Time spans whose rolling RMS exceeds ``limit`` times the median rolling RMS, largest first.

    Temporaries of at most two arrays the size of the log at once (an hour at 1 kHz is 29 MB each: this ran
    at the diagnosis' peak memory)."""
    dt = float(t[1] - t[0])
    w = max(int(window_s / dt), 1)
    if r.size < 2 * w:
        return []
    c = np.empty(r.size + 1)
    c[0] = 0.0
    np.cumsum(np.square(r), out=c[1:])
    rms = c[w:] - c[:-w]  # the window sums of r^2
    del c
    rms /= w
    np.sqrt(rms, out=rms)
    base = float(np.median(rms)) or 1e-300
    hot = np.concatenate([[False], rms > limit * base, [False]])
    out = []
    edges = np.flatnonzero(hot[1:] != hot[:-1])  # starts and ends (exclusive) of the runs of hot windows
    del hot
    for s, e in zip(edges[::2], edges[1::2]):
        i0, i1 = s, min(e - 1 + 2 * (w // 2), r.size - 1)  # window k is centred on sample k + w // 2
        seg = slice(i0, i1 + 1)
        ctx = []
        vel = context["velocity"][seg]
        if np.any(np.diff(np.sign(vel[np.abs(vel) > 1e-3])) != 0):
            ctx.append("velocity reversal")
        u = context["input"][seg]
        if np.mean(np.abs(u) >= 0.98 * context["input_limit"]) > 0.1:
            ctx.append("input at its limit")
        if np.max(np.abs(context["angle"][seg])) >= 0.8 * context["angle_max"]:
            ctx.append("large angle")
        if np.mean(np.abs(u) < 0.3) > 0.5:
            ctx.append("small input")
        out.append({"start_s": float(t[i0]), "end_s": float(t[i1]), "rms_ratio": float(rms[s:e].max() / base),
                    "context": ctx})
    out.sort(key=lambda d: -d["rms_ratio"])
    return out[:most]


def regimes(r: np.ndarray, velocity: np.ndarray, angle: np.ndarray, u: np.ndarray) -> dict:
    """Residual statistics against the regime variables (units of the filtered torque, N m)."""
    out = {}
    pos, neg = velocity > 0, velocity < 0
    if pos.any() and neg.any():
        out["mean_residual_moving_positive"] = float(r[pos].mean())
        out["mean_residual_moving_negative"] = float(r[neg].mean())
    da = angle - angle.mean()
    var = float(np.dot(da, da))
    if var > 0:  # the least-squares slope of r against the angle (numpy.polyfit's, without its n x 2 matrix)
        out["residual_slope_per_rad"] = float(np.dot(da, r)) / var
    del da
    small = np.abs(u) < 0.3
    if small.any() and (~small).any():
        out["rms_residual_small_input"] = float(np.sqrt(np.mean(r[small] ** 2)))
        out["rms_residual_other_input"] = float(np.sqrt(np.mean(r[~small] ** 2)))
    return out


def lag_profile(delays_s: list[float], gains: list[float]) -> dict:
    if not delays_s:
        return {}
    i = int(np.argmax(gains))
    return {"best_delay_s": float(delays_s[i]), "gain_at_best": float(gains[i])}
