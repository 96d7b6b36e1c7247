"""Figures in the spirit of the paper's: signals used (Figs. 2-3) and estimate traces (Figs. 4-5)."""
from __future__ import annotations

from typing import TYPE_CHECKING

import base64
import io

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..log import Log  # noqa: E402
from ..params import UNITS  # noqa: E402

if TYPE_CHECKING:
    from ..identify import Result

MAX_POINTS = 4000  # per line; longer signals are strided for drawing only


def stride(n: int) -> slice:
    return slice(None, None, max(1, n // MAX_POINTS))


def png_data_uri(fig) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=96, bbox_inches="tight", metadata={"Software": None})
    plt.close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def signals_figure(log: Log) -> str:
    s = stride(len(log))
    t = log.t_s[s]
    fig, ax = plt.subplots(2, 2, figsize=(10, 5), sharex=True)
    for a, y, label in ((ax[0, 0], log.u1_v, "u1 [V]"), (ax[0, 1], log.u2_v, "u2 [V]"),
                        (ax[1, 0], log.alpha_rad, "alpha (pitch) [rad]"), (ax[1, 1], log.beta_rad, "beta (yaw) [rad]")):
        a.plot(t, y[s], lw=0.8)
        a.set_ylabel(label)
        a.grid(alpha=0.3)
    for a in ax[1]:
        a.set_xlabel("t [s]")
    fig.suptitle("Signals used: motor voltages and measured angles")
    return png_data_uri(fig)


def _limits(result: Result, name: str, truth: dict | None) -> tuple[float, float]:
    """Every line in view: the trace after its first 5 %, the estimates, the intervals and the truth."""
    tr = result.traces[name]
    vals = [tr[tr.size // 20:], [result.offline[name]]]
    for ci in (result.offline_intervals[name], result.intervals[name]):
        if np.isfinite(ci.low):
            vals.append([ci.low, ci.high])
    if result.refined is not None:
        vals.append([result.refined.estimate[name]])
    if truth:
        vals.append([truth[name]])
    v = np.concatenate([np.asarray(x, dtype=float).ravel() for x in vals])
    v = v[np.isfinite(v)]
    lo, hi = (float(v.min()), float(v.max())) if v.size else (0.0, 1.0)
    pad = 0.1 * (hi - lo) or 0.05 * abs(hi) or 1.0
    return lo - pad, hi + pad


def compare_plot(log: Log, simulated: np.ndarray | None, check: dict):
    """Measured against model-simulated angles, with the fit in %, as MATLAB's ``compare`` draws them (a
    matplotlib Figure; measured only where there is no simulation)."""
    m = len(log) if simulated is None else simulated.shape[0]
    s = stride(m)
    t = log.t_s[:m][s]
    fig, ax = plt.subplots(2, 1, figsize=(10, 5.5), sharex=True)
    for j, (a, y, axis, label) in enumerate(((ax[0], log.alpha_rad, "pitch", "alpha [rad]"),
                                             (ax[1], log.beta_rad, "yaw", "beta [rad]"))):
        c = check["axes"].get(axis, {})
        a.plot(t, y[:m][s], color="0.35", lw=1.0, label="measured")
        if simulated is not None:
            a.plot(t, simulated[s, j], color="tab:blue", lw=0.9, ls="--",
                   label=f"model: fit {c.get('fit_percent', float('nan')):.2f} % (noise floor allows "
                         f"{c.get('noise_floor_fit_percent', float('nan')):.2f} %)")
        a.set_ylabel(label)
        a.grid(alpha=0.3)
        a.legend(fontsize=8, loc="upper right")
    ax[1].set_xlabel("t [s]")
    fig.suptitle("Measured and simulated angles (" + {True: "the model fits", False: "the model does NOT fit",
                                                      None: "fit not decided"}[check["adequate"]] + ")")
    return fig


def compare_figure(log: Log, simulated: np.ndarray, check: dict) -> str:
    """compare_plot as an embedded PNG for the report."""
    return png_data_uri(compare_plot(log, simulated, check))


def residual_figure(log: Log, simulated: np.ndarray, dt_s: float, skip: tuple = ()) -> str:
    """Residual autocorrelation and residual-input cross-correlation with their 99 % bands (as ``resid``), one
    row per axis but those in ``skip`` (where the tests do not apply: adequacy.model_check)."""
    from ..numerics.adequacy import LAGS, correlation_functions, decimation

    m = simulated.shape[0]
    step = decimation(dt_s)
    rows = [(j, y, axis) for j, (y, axis) in enumerate(((log.alpha_rad, "pitch"), (log.beta_rad, "yaw")))
            if axis not in skip]
    fig, ax = plt.subplots(len(rows), 3, figsize=(11, 0.5 + 2.5 * len(rows)), squeeze=False)
    lags = np.arange(-LAGS, LAGS + 1) * step * dt_s
    for row, (j, y, axis) in enumerate(rows):
        e = (y[:m] - simulated[:, j])[::step]
        for i, u in enumerate((log.u1_v, log.u2_v)):
            ud = np.add.reduceat(u[:m], np.arange(0, m, step))[:e.size] / step
            auto, cross, band = correlation_functions(e, ud)
            if i == 0:
                a = ax[row, 0]
                a.stem(np.arange(LAGS + 1) * step * dt_s, auto, basefmt=" ")
                a.axhspan(-band, band, color="tab:blue", alpha=0.15, lw=0)
                a.set_title(f"{axis}: residual autocorrelation", fontsize=9)
            a = ax[row, 1 + i]
            a.stem(lags, cross, basefmt=" ")
            a.axhspan(-band, band, color="tab:blue", alpha=0.15, lw=0)
            a.set_title(f"{axis}: residual x u{i + 1} (u leads for lag > 0)", fontsize=9)
    for a in ax.ravel():
        a.grid(alpha=0.3)
    for a in ax[-1]:
        a.set_xlabel("lag [s]")
    fig.suptitle(f"Residual tests on the residual decimated to every {step}th sample (99 % band shaded)")
    fig.tight_layout()
    return png_data_uri(fig)


def traces_figure(result: Result, truth: dict | None) -> str:
    s = stride(result.t_s.size)
    t = result.t_s[s]
    fig, ax = plt.subplots(2, 2, figsize=(10, 5.5), sharex=True)
    for a, name in zip(ax.ravel(), ("J1", "B1", "J2", "B2")):
        a.plot(t, result.traces[name][s], lw=1.0, label="DREM trace (eq. 8)")
        a.axhline(result.offline[name], color="tab:green", ls=":", lw=1.2, label="offline optimum")
        ci = result.offline_intervals[name]
        if np.isfinite(ci.low):
            a.axhspan(ci.low, ci.high, color="tab:green", alpha=0.15, lw=0, label="95 % interval (offline)")
        if result.refined is not None:
            a.axhline(result.refined.estimate[name], color="tab:red", ls="-.", lw=1.2,
                      label="refined" + ("" if result.headline == "refined" else " (not used)"))
        head = result.intervals[name]
        if result.headline == "refined" and np.isfinite(head.low):
            a.axhspan(head.low, head.high, color="tab:red", alpha=0.25, lw=0, label="95 % interval (refined)")
        if truth:
            a.axhline(truth[name], color="k", ls="--", lw=1.0, label="ground truth")
        a.set_ylim(*_limits(result, name, truth))
        a.set_ylabel(f"{name} [{UNITS[name]}]")
        a.grid(alpha=0.3)
    for a in ax[1]:
        a.set_xlabel("t [s]")
    ax[0, 0].legend(fontsize=8, loc="lower right")
    fig.suptitle("Parameter estimates over time")
    return png_data_uri(fig)

