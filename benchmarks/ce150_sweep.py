"""Do the CE150 recordings follow the published model?  Each axis checked on its own, against the published values.

    python benchmarks/ce150_sweep.py [--folder DIR ...]

The CE150 files (../shared/real_logs/ce150 by default; the public repository JurCag/NN_for_FF_Compensation holds
ten Data100_*.mat) are simulations of the authors' published Simulink model (tests/plants/ce150.py ports it).  For
each file holding u1, u2, psi and phi (100 Hz, degrees):

- the azimuth's steady balance over the middle third: its recorded rate against the rate at which the published
  model turns at those inputs, (Tau_2(u2) - K_r u1) / B_phi (the azimuth has no other torque in that model);
- the azimuth simulated on its own (it does not depend on the elevation in that model) with the ported equations,
  its start states fitted (rate, the tail motor's two states, the reaction lag's), then with B_phi free, then with
  K_r, B_phi and I_phi free, then with the published values and a Coulomb friction F_c sign(phi') added (the
  port's F_c, 0 in the published model), F_c free (scipy.optimize.least_squares): the error RMS [deg] each leaves;
- the elevation simulated with the published values, driven by the measured azimuth rate (a cubic spline's
  derivative) in its gyroscopic term, from the file's first angle and rate with the motor settled at u1: the
  error's maximum and RMS [deg] (not on a file whose elevation rests on its 45 degree stop: no stop here).

Nothing here uses the tool: it says what the files are, so that the tool's answers on them can be judged.  Prints
Markdown for RESULTS.md.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline
from scipy.io import loadmat
from scipy.io.matlab import MatReadError
from scipy.optimize import least_squares

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.plants import ce150  # noqa: E402

P = ce150.P
RATE_HZ = 100.0


def _columns(path: Path) -> dict | None:
    try:
        d = loadmat(path)
    except (MatReadError, ValueError, OSError):  # not a .mat file scipy reads (an empty one, MATLAB objects)
        return None
    if not all(k in d for k in ("u1", "u2", "psi", "phi")):
        return None
    out = {k: np.asarray(d[k], dtype=float).ravel() for k in ("u1", "u2", "psi", "phi")}
    out["t"] = np.arange(out["u1"].size) / RATE_HZ
    return out


def steady(c: dict) -> tuple[float, float]:
    """(recorded, published) azimuth rate [deg/s] over the middle third."""
    n = c["u1"].size
    m = slice(n // 3, 2 * n // 3)
    rate = float(np.mean(np.gradient(c["phi"], 1.0 / RATE_HZ)[m]))
    u1, u2 = float(np.mean(c["u1"][m])), float(np.mean(c["u2"][m]))
    torque = P["a_2"] * u2 * u2 + P["b_2"] * u2 - P["K_r"] * u1
    return rate, math.degrees(torque / P["B_phi"])


def yaw_fit(c: dict, free: tuple, first: dict | None = None) -> tuple[float, dict]:
    """(error RMS [deg], the free values) of the azimuth simulated by the ported model, its start states and the
    values in ``free`` fitted, from the published values or ``first``."""
    phi = np.radians(c["phi"])
    t, u1, u2 = c["t"], c["u1"], c["u2"]
    dphi0 = (phi[1] - phi[0]) * RATE_HZ

    def sim(x):
        p = dict(zip(free, x[4:]))
        x0 = ce150.rest_state(u1[0], u2[0], psi=math.radians(c["psi"][0]), phi=phi[0])
        x0[3], x0[6], x0[7], x0[8] = x[0], x[1], x[2], x[3]  # phi', the tail motor's two states, the reaction lag
        return ce150.open_loop(t, u1, u2, x0, p)[:, 1]

    x0 = np.array([dphi0, u2[0], u2[0], u1[0]] + [{**P, **(first or {})}[k] for k in free])
    r = least_squares(lambda x: np.degrees(sim(x) - phi), x0, x_scale="jac")
    return float(np.sqrt(np.mean(r.fun ** 2))), dict(zip(free, r.x[4:]))


def yaw_coulomb_fit(c: dict) -> tuple[float, float]:
    """(error RMS [deg], fc [N m]) of the azimuth with the published values and a Coulomb friction F_c (the ported
    model's, its sign smoothed), F_c and the start states fitted."""
    rms, values = yaw_fit(c, ("F_c",), {"F_c": 3e-4})
    return rms, values["F_c"]


def pitch_driven(c: dict) -> tuple[float, float]:
    """(max, RMS) [deg] of the elevation simulated with the published values and the measured azimuth rate."""
    t, u1 = c["t"], c["u1"]
    psi = np.radians(c["psi"])
    rate = CubicSpline(t, np.radians(c["phi"])).derivative()
    q = P

    def f(tt, x):
        a, da, z1, w1 = x
        u = float(np.interp(tt, t, u1))
        tau = q["a_1"] * w1 * w1 + q["b_1"] * w1
        dd = (tau - q["B_psi"] * da - q["K_Gyro"] * math.cos(a) * float(rate(tt)) * u
              - q["Tau_g"] * math.sin(a)) / q["I"]
        return [da, dd, (u - z1) / q["T_1"], (z1 - w1) / q["T_1"]]

    s = solve_ivp(f, (t[0], t[-1]), [psi[0], (psi[1] - psi[0]) * RATE_HZ, u1[0], u1[0]], t_eval=t, rtol=1e-10,
                  atol=1e-12, max_step=0.01)
    e = np.degrees(s.y[0] - psi)
    return float(np.max(np.abs(e))), float(np.sqrt(np.mean(e ** 2)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--folder", action="append", help="a folder of Data100_*.mat (default ../shared/real_logs/ce150)")
    args = ap.parse_args()
    folders = [Path(f) for f in (args.folder or [ROOT.parent / "shared" / "real_logs" / "ce150"])]
    files = sorted({p.name: p for f in folders for p in f.glob("*.mat")}.values(), key=lambda p: p.name)
    print("| file | azimuth rate, recorded / published model [deg/s] | azimuth error RMS [deg]: published | "
          "B_phi free | K_r, B_phi, I_phi free (their values) | published + a Coulomb friction fc | elevation "
          "driven by the measured azimuth: max, RMS [deg] |")
    print("|---|---|---|---|---|---|---|")
    for path in files:
        c = _columns(path)
        if c is None:
            print(f"| {path.name} | not checked (no u1, u2, psi and phi) | | | | | |")
            continue
        rec, pub = steady(c)
        moving = abs(rec) > 0.1
        fits = [yaw_fit(c, free) for free in ((), ("B_phi",), ("K_r", "B_phi", "I_phi"))] if moving else []
        on_stop = float(np.min(c["psi"])) <= math.degrees(ce150.PSI_STOPS[0]) + 1e-6
        pitch = "on its 45 deg stop at times: not checked" if on_stop else "{:.2g}, {:.2g}".format(*pitch_driven(c))
        if fits:
            coulomb = yaw_coulomb_fit(c)
            yaw = " | ".join([f"{fits[0][0]:.2g}", f"{fits[1][0]:.2g} (B_phi {fits[1][1]['B_phi']:.4g})",
                              f"{fits[2][0]:.2g} (" + ", ".join(f"{k} {v:.4g}" for k, v in fits[2][1].items()) + ")",
                              f"{coulomb[0]:.2g} (fc {coulomb[1]:.3g} N m)"])
        else:
            yaw = "held near 0 (not fitted) | - | - | -"
        print(f"| {path.name} | {rec:.3g} / {pub:.3g} | {yaw} | {pitch} |")


if __name__ == "__main__":
    main()
