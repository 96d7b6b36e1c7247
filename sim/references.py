"""Reference trajectories for the closed loop [rad], as functions of time [s].

``square`` and ``sine`` are the paper's two experiments exactly; the others are
richer excitations.  Random ones (``steps``, ``multisine`` phases) take an explicit seed.
"""
from __future__ import annotations

import numpy as np

REFERENCES = ("square", "sine", "multisine", "steps", "chirp")
#: the reference read from a table (a file: ``trms-ident simulate --ref-file``), not one of the built-in shapes
TABLE = "file"


def reference(name: str, t_s: np.ndarray, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(alpha_ref, beta_ref) in rad at times ``t_s``."""
    t = np.asarray(t_s, dtype=float)
    rng = np.random.default_rng(seed)
    if name == "square":  # paper, experiment 1
        s = np.sign(np.sin(np.pi * t))
        return 0.5 * s, 0.3 * s
    if name == "sine":  # paper, experiment 2
        return 0.5 * np.sin(0.5 * t), 0.2 * np.sin(0.3 * t)
    ramp = np.clip(t / 2.0, 0.0, 1.0)  # start from rest without a jump
    if name == "multisine":
        freqs_hz = np.array([0.05, 0.11, 0.23, 0.37, 0.61, 0.97])
        amps = 1.0 / np.sqrt(freqs_hz / freqs_hz[0])
        amps /= amps.sum()
        ph_a, ph_b = rng.uniform(0, 2 * np.pi, (2, freqs_hz.size))
        a = (amps[:, None] * np.sin(2 * np.pi * freqs_hz[:, None] * t + ph_a[:, None])).sum(0)
        b = (amps[:, None] * np.sin(2 * np.pi * freqs_hz[:, None] * t + ph_b[:, None])).sum(0)
        return 0.5 * ramp * a, 0.4 * ramp * b
    if name == "steps":
        hold = rng.uniform(0.8, 3.0, 4096)
        edges = np.concatenate([[0.0], np.cumsum(hold)])
        la, lb = rng.uniform(-0.55, 0.55, 4096), rng.uniform(-0.5, 0.5, 4096)
        la[0] = lb[0] = 0.0
        idx = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, 4095)
        return la[idx], lb[idx]
    if name == "chirp":  # 0.02 -> 1 Hz logarithmic sweep, restarted every 60 s
        tau = np.mod(t, 60.0)
        f0, f1 = 0.02, 1.0
        k = np.log(f1 / f0) / 60.0
        phase = 2 * np.pi * f0 * (np.exp(k * tau) - 1) / k
        return 0.45 * ramp * np.sin(phase), 0.35 * ramp * np.sin(phase + 0.7)
    raise ValueError(f"unknown reference {name!r}; expected one of {', '.join(REFERENCES)}")


def tabulated(table: tuple, t_s: np.ndarray, slack_s: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """(alpha_ref, beta_ref) in rad at times ``t_s`` from ``table`` = (times [s], alpha_ref [rad], beta_ref [rad]),
    linear between its rows; a time more than ``slack_s`` past its end (jittered stamps) is an error, never an
    extrapolation (within the slack the last row holds)."""
    tt, a, b = (np.asarray(x, dtype=float) for x in table)
    t = np.asarray(t_s, dtype=float)
    if t.size and (t[0] < tt[0] or t[-1] > tt[-1] + slack_s + 1e-9 * max(1.0, abs(tt[-1]))):
        raise ValueError(f"the reference table covers {tt[0]:.6g} to {tt[-1]:.6g} s; the run needs "
                         f"{t[0]:.6g} to {t[-1]:.6g} s")
    return np.interp(t, tt, a), np.interp(t, tt, b)
