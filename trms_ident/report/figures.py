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


def _stride(n: int) -> slice:
    return slice(None, None, max(1, n // MAX_POINTS))


def png_data_uri(fig) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=96, bbox_inches="tight", metadata={"Software": None})
    plt.close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def signals_figure(log: Log) -> str:
    s = _stride(len(log))
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


def traces_figure(result: Result, truth: dict | None) -> str:
    s = _stride(result.t_s.size)
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
        if truth:
            a.axhline(truth[name], color="k", ls="--", lw=1.0, label="ground truth")
            lo, hi = sorted((0.0, 1.3 * truth[name]))
            a.set_ylim(lo, hi) if np.isfinite(hi) and hi > lo else None
        a.set_ylabel(f"{name} [{UNITS[name]}]")
        a.grid(alpha=0.3)
    for a in ax[1]:
        a.set_xlabel("t [s]")
    ax[0, 0].legend(fontsize=8, loc="lower right")
    fig.suptitle("Parameter estimates over time")
    return png_data_uri(fig)

