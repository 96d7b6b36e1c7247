"""Where the nominal model's equation error is large: in time, by operating regime, by lag."""
from __future__ import annotations

import numpy as np


def segments(t: np.ndarray, r: np.ndarray, window_s: float, context: dict[str, np.ndarray],
             limit: float = 2.0, most: int = 5) -> list[dict]:
    """Time spans whose rolling RMS exceeds ``limit`` times the median rolling RMS, largest first."""
    dt = float(t[1] - t[0])
    w = max(int(window_s / dt), 1)
    if r.size < 2 * w:
        return []
    c = np.concatenate([[0.0], np.cumsum(r * r)])
    rms = np.sqrt((c[w:] - c[:-w]) / w)
    centre = np.arange(rms.size) + w // 2
    base = float(np.median(rms)) or 1e-300
    hot = rms > limit * base
    out = []
    edges = np.flatnonzero(np.diff(np.concatenate([[0], hot.astype(int), [0]])))
    for s, e in zip(edges[::2], edges[1::2]):
        i0, i1 = centre[s] - w // 2, min(centre[e - 1] + w // 2, r.size - 1)
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
    if np.std(angle) > 0:
        out["residual_slope_per_rad"] = float(np.polyfit(angle, r, 1)[0])
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
