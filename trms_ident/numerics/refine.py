"""Prediction-error refinement of J1, B1, J2, B2, started from the DREM estimate (offline stage).

DREM's offline optimum (eq. 7) is consistent but not efficient: the filters weight the data
by their design, not by the noise, and angle noise reaches the regressor F s^2[x] (errors in
variables).  The prediction-error estimate minimises the angle errors themselves, which for
white angle noise is the maximum-likelihood estimate.  It is a nonlinear least-squares
problem; from DREM's estimate Gauss-Newton converges in a few steps, so DREM supplies what an
output-error fit lacks on its own: a start inside the basin.  A model that does not fit the log
leaves angle errors above the noise level; the caller (identify) then keeps DREM's estimate.

Model: paper eq. (1), both axes together (the pitch equation takes beta' from the model, not
differentiated from the log), state [alpha, alpha', beta, beta', tau1, tau2, zeta] with zeta
the lag state of M_R = kc (T0 s + 1)/(Tp s + 1) tau1, plus the effects of EFFECT_SLOTS when diagnose
puts a candidate in (friction, drag, cable, thrust asymmetry, centre-of-mass offset, a pitch-dependent yaw
inertia, the pitch encoder's zero offset; 0 = absent: model/plant.py), and
exogenous torques: effects diagnose's model room declares by their torque, computed by the caller from the
measured states (refine's ``torques``).  The
logged voltages are held over each actual sample interval t[k]..t[k+1] (the bench's controller holds them;
jittered stamps are integrated over their real length), classical RK4 in sub-steps of at most MAX_SUBSTEP_S
advances the state together with its sensitivities (forward sensitivity equations: one pass
gives the Gauss-Newton system).

Unknowns.  Global: J1, B1, J2, B2 and the motors' and the reaction lag's states when the log
begins, tau1(0), tau2(0), zeta(0), and a second-order motor's further lag state lag1(0), lag2(0) (a log
starts from rest with the controller driving, or mid-run: these are never assumed, as greyest does with
InitialState='estimate').  The motor
states run on continuously through the whole log; they depend on no J/B or angle, so they are integrated
first (motor_starts, once per set of motor values: they are linear in their start states) and the windows
then run independently, in threads on the machine's cores, each window computed the same way whatever the
split.  Per window of WINDOW_S seconds: the angles
and angular rates at the window's first sample (so a model error cannot accumulate over the
whole log, yaw has no restoring force), eliminated by a Schur complement.  No sample is left
out.  The angle errors are weighted by each angle's noise level.  Interval: batch means over
BLOCK_S blocks of the scores of J/B with every nuisance unknown projected out (valid for
correlated errors, e.g. quantization).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit
from scipy.special import stdtrit

from . import parallel, safe
from .kernel_args import HELPER, readonly
from ..model.structure import of_bench, slot_values
from ..model.plant import (FRICTION_SMOOTH_RAD_S, GRAVITY_OFFSET_SLOT, GYRO_VOLTAGE_SLOT, LAG1_SLOT, LAG2_SLOT,
                           N_SLOTS, PARAM_ORDER, REACTION_VOLTAGE_SLOT, SENSOR_OFFSET_SLOT, STOP_SLOT,
                           YAW_INERTIA_SLOT, centrifugal_pitch, coriolis_yaw, coulomb_sign,
                           friction, lag_rate, model_vector, motor_rate, pitch_torque, reaction_moment, reversed_gain,
                           slot, steady_motor_states, thrust, thrust_slope, yaw_inertia, yaw_torque)

#: window length [s]: long against the pitch damping time J1/B1 (~11 s) is best for B1 and J1 (over 10
#: noise seeds of a 120 s multisine at 200 Hz, 1 mrad: J1 rms error 0.023 % with 10 s windows, 0.018 % with
#: 20 s, 0.012 % with 40 s or one window), and windows stop model errors piling up over a whole log
WINDOW_S = 40.0
#: multiple shooting's window [s]: one interval block, about a motor time constant (2 s left a 6 s log cut
#: mid-run in a wrong basin of the tail motor's start state; 0.5-1 s found the optimum).  Each window restarts
#: from its own fitted angles and rates, so a start state's error cannot pile up: estimate's refinement falls back
#: to it (identify) and the known values' search starts there (known_values)
SHOOTING_WINDOW_S = 1.0
#: RK4 sub-step: the integrator's error on noise-free logs is ~1e-10 relative at 2.5 ms (measured)
MAX_SUBSTEP_S = 2.5e-3
#: RK4 sub-step while a Coulomb friction is in the model (in its effects or freed): its smoothed sign,
#: tanh(omega / FRICTION_SMOOTH_RAD_S), makes the right side stiff near zero rate (time constant J eps / Fc, 7 ms on
#: the yaw of a 0.0028 N m friction), and RK4 at 2.5 ms moved the friction's estimate: a yaw friction freed came
#: out 4.8 % low, 5.6 half-widths of its interval off (a 200 Hz square wave cut mid-run); at 0.5 ms 0.54 % low
#: (0.73 half-widths), at 0.1 ms 0.42 % (measured, benchmarks/freed_coverage.py)
COULOMB_SUBSTEP_S = 5e-4
#: the RK4 sub-step's bound [s] in a trial fit (a profile's or a screen's, whose values, cost and predictions alone
#: are used: refine's ``substep_s``), one step a sample on logs at 100 Hz and faster: the angles move by 6e-9 rad
#: against MAX_SUBSTEP_S's (measured on a 100 Hz steps log and a multisine with a 0.05 s second-order motor), 1e-5
#: of a noise floor, and a 100 Hz log's trial fit integrates 4x fewer steps.  Not with a Coulomb friction in the
#: model (COULOMB_SUBSTEP_S: stiff)
TRIAL_SUBSTEP_S = 0.01
#: ... where the angles' noise floors are both at least this [rad] (trial_substep): 1e3 times the trial's own error,
#: so the trial fits' costs stand beside a fine fit's (a profile's drops are measured from one); a log with hardly
#: any noise (a noise-free simulation) keeps the fine sub-step
TRIAL_MIN_FLOOR_RAD = 1e-5
COULOMB_KEYS = ("coulomb_friction:pitch", "coulomb_friction:yaw")
MAX_ITERATIONS = 25  # typical logs take 3-4; a start far off (DREM on a log cut mid-run) needed 12
#: Gauss-Newton stops when the next step would move every unknown by less than this fraction of its value, or
#: by less than STEP_OVER_SE of its standard error; or when it would lower the noise-weighted cost (a chi^2) by
#: less than MIN_COST_DECREASE while moving J/B by less than JB_STEP_OVER_SE of their standard errors: a nearly
#: undetermined start state (tau2(0) of a log cut mid-run, standard error 0.2) otherwise kept the steps
#: dithering at the noise floor for 25 iterations, gaining 0.04-0.08 in chi^2 each
TOLERANCE = 1e-11
STEP_OVER_SE = 1e-2
MIN_COST_DECREASE = 0.1
JB_STEP_OVER_SE = 0.1
BLOCK_S = 1.0
#: intervals narrower than this fraction of the estimate get the integrator's error added, at sub-steps of
#: MAX_SUBSTEP_S (the integrator's error there, ~1e-10, is 1e4 times smaller); RK4's error falls as the
#: sub-step's 4th power, so at shorter sub-steps the threshold falls with it (1 kHz: 2.6e-8)
RICHARDSON_BELOW = 1e-6
NAMES = ("J1", "B1", "J2", "B2")
#: the start states estimated with J/B (global unknowns 4..6)
START_NAMES = ("tau1_0", "tau2_0", "zeta_0")
NG = 7  # global unknowns: J1, B1, J2, B2, tau1(0), tau2(0), zeta(0)
NL = 4  # per-window unknowns: alpha, alpha', beta, beta' at the window's first sample
NU = NG + NL
#: a second-order motor's further lag state at the first sample (the drive its first-order lag sees [V]): estimated
#: with J/B when that motor's T2 > 0, as the other start states are (absent from the unknowns otherwise, where it
#: acts on nothing).  Inside the kernel each is an unknown with exact sensitivities like a freed value, at these
#: slots of its own (below 0: no model-vector value)
LAG_START_NAMES = ("lag1_0", "lag2_0")
LAG_START_SLOTS = {"lag1_0": -3, "lag2_0": -4}
# the model vector handed to the compiled kernel (model/plant.py): the table's values, the gravity offset, the
# effects' slots, then exogenous torques' parameters
_P = PARAM_ORDER
_NP = N_SLOTS
# state layout: [0:7] alpha, alpha', beta, beta', tau1, tau2, zeta; then per unknown c in the NU order (J1, B1,
# J2, B2, tau1(0), tau2(0), zeta(0), alpha0, alpha'0, beta0, beta'0) the sensitivities of alpha, alpha', beta,
# beta' at [7 + 4c : 11 + 4c]; then the motor-state sensitivities d tau1/d tau1(0), d tau2/d tau2(0),
# d zeta/d tau1(0), d zeta/d zeta(0) at [51:55]; then a second-order motor's further lag states (the drives the
# motors see, model.plant.LAG_SLOTS; unused when its T2 is 0) at [55:57]; then their start states' sensitivities
# d lag1/d lag1(0), d tau1/d lag1(0), d zeta/d lag1(0), d lag2/d lag2(0), d tau2/d lag2(0) at [57:62]; then the
# freed values' sensitivities (and the lag starts' when estimated: LAG_START_SLOTS)
_S0 = 7
_MS = _S0 + 4 * NU  # 51
_LAG = _MS + 4  # 55
_LS = _LAG + 2  # 57
_NS = _LS + 5


@dataclass(frozen=True)
class Refined:
    estimate: dict  # J1, B1, J2, B2
    ci95: dict  # name -> (low, high)
    converged: bool
    iterations: int
    rms_rad: dict  # angle error RMS after refinement, per angle [rad]
    cost: float  # sum of squared noise-weighted angle errors at the estimate (2 angles x samples used)
    window_s: float
    windows: int
    substeps: int  # RK4 sub-steps in a median sample interval
    blocks: int
    integration_error: dict  # estimated parameter error of the RK4 integration (0 when not needed)
    #: tau1_0, tau2_0, zeta_0 (model units of tau), alpha_dot_0_rad_s, beta_dot_0_rad_s, and a second-order motor's
    #: further lag state lag1_0 / lag2_0 [V] where it is one
    start_states: dict
    start_states_se: dict  # their standard errors (same keys)
    prediction: np.ndarray  # (n, 2) simulated alpha, beta [rad] at the estimate (per-window restarts)
    freed: dict  # known values estimated with J/B (--free): name -> estimate, ci95, the value given
    fit: object = None  # _Fit, for score tests on further unknowns (suspect_known_values)
    pending_decrease: float = 0.0  # the decrease in cost one more full Gauss-Newton step predicts at the estimate
    cov_jb: np.ndarray | None = None  # (4, 4) batch-means covariance of J1, B1, J2, B2 (NAMES' order)


@njit(cache=True, nogil=True, fastmath={"contract", "reassoc", "arcp"}, inline="always")
def _direct(slot, x, p, signed, g1, g2, m1, gd, rd, sg, cg, sa, ca, f3, fe1, fe2):
    """The torques' derivatives [N m per unit] on pitch and yaw (eq. 1) in the model value at ``slot`` with the
    state held: the direct term of that value's forward sensitivity (the caller divides by J1 and by the yaw
    inertia).  Every slot but the motors' (k1, k2, T11, T10, T21, T20, Tp: they act through the motor states,
    DIRECT_SLOTS leaves them out).  f3: beta'' now.  fe1, fe2: an exogenous torque's per-unit torques at this
    instant (slots from _NP on).  The encoder offset has none: it acts on the logged angle (windows_pass).  gd, rd:
    the gyroscope's and M_R's drives (M1 and tau1 in eq. 1, the voltage u1 under the bench's structure)."""
    # d(pitch torque)/d M1: the thrust and its gyroscopic coupling (none when the voltage drives the gyroscope: the
    # slot holds 1; blended, not branched, as everywhere in these kernels: a test of a slot inside them made the
    # refinement with freed values 50 % slower)
    gyro = 1.0 - (1.0 - p[GYRO_VOLTAGE_SLOT]) * p[9] * x[3] * ca
    if slot == 4:  # a1: d thrust / d a = tau^2 (or tau|tau|)
        return g1 * thrust(x[4], 1.0, 0.0, signed) * gyro, 0.0
    if slot == 5:  # b1
        return g1 * thrust(x[4], 0.0, 1.0, signed) * gyro, 0.0
    if slot == 6:  # a2
        return 0.0, g2 * thrust(x[5], 1.0, 0.0, signed)
    if slot == 7:  # b2
        return 0.0, g2 * thrust(x[5], 0.0, 1.0, signed)
    if slot == 8:  # Mg
        return -sg, 0.0
    if slot == 9:  # Kg
        return -gd * x[3] * ca, 0.0
    if slot == 16:  # kc: M_R is linear in kc
        return 0.0, -reaction_moment(rd, x[6], 1.0, p[17], p[18])
    if slot == 17:  # T0
        return 0.0, -p[16] * (rd - x[6]) / p[18]
    if slot == GRAVITY_OFFSET_SLOT:  # centre-of-mass offset delta in Mg sin(alpha + delta)
        return -p[8] * cg, 0.0
    if slot == 20:  # Coulomb friction, pitch: the rate's smoothed sign (_rhs computes it only for a friction
        # that is not 0, and a freed one starts at 0)
        return -coulomb_sign(x[1]), 0.0
    if slot == 21:
        return 0.0, -coulomb_sign(x[3])
    if slot == 22:  # quadratic drag, pitch
        return -x[1] * abs(x[1]), 0.0
    if slot == 23:
        return 0.0, -x[3] * abs(x[3])
    if slot == 24:  # cable stiffness
        return 0.0, -x[2]
    if slot == 25:  # thrust asymmetry of a reversed rotor: (1 + s) times the thrust for tau < 0
        return (thrust(x[4], p[4], p[5], signed) * gyro if x[4] < 0.0 else 0.0), 0.0
    if slot == 26:
        return 0.0, (thrust(x[5], p[6], p[7], signed) if x[5] < 0.0 else 0.0)
    if slot == YAW_INERTIA_SLOT:  # dJ: its Lagrange torques, and beta'' through J2 - dJ sin^2(alpha)
        return (centrifugal_pitch(1.0, sa, ca, x[3]),
                coriolis_yaw(1.0, sa, ca, x[1], x[3]) + sa * sa * f3)
    if slot == SENSOR_OFFSET_SLOT:
        return 0.0, 0.0
    if slot == -3:  # lag1(0): through tau1, M1 and M_R's direct and lagged paths, as tau1(0)
        through_tau1 = (1.0 - p[REACTION_VOLTAGE_SLOT]) * p[17] / p[18] * x[_LS + 1]
        return (g1 * thrust_slope(x[4], p[4], p[5], signed) * gyro * x[_LS + 1],
                -p[16] * (through_tau1 + (1.0 - p[17] / p[18]) * x[_LS + 2]))
    if slot == -4:  # lag2(0): through tau2 and M2
        return 0.0, g2 * thrust_slope(x[5], p[6], p[7], signed) * x[_LS + 4]
    return fe1, fe2  # an exogenous torque's parameter


@njit(cache=True, nogil=True, inline="always")
def _drive(u, lag, t2):
    """The voltage a motor's first-order lag sees: u itself, or a second-order motor's further lag state (T2 > 0)."""
    return lag if t2 > 0.0 else u


@njit(cache=True, nogil=True, inline="always")
def _lag_drive_rate(u, lag, t2):
    """The further lag's rate, 1/(T2 s + 1) of the held voltage u (0 when T2 = 0: no lag)."""
    return (u - lag) / t2 if t2 > 0.0 else 0.0


@njit(cache=True, nogil=True, fastmath={"contract", "reassoc", "arcp"}, **HELPER)
def _rhs(x, u1, u2, e1, e2, p, signed, d, fs, fe, sens=True):
    """Paper eq. (1) with the motor lags, M_R's lag state and the effects in p's slots, and the exact forward
    sensitivities (layout above): for every unknown c, d/dt S_c = A(t) S_c + df/dtheta_c, with A the Jacobian
    of (alpha', alpha'', beta', beta'') in (alpha, alpha', beta, beta').  e1, e2: exogenous torques [N m] on
    pitch and yaw (effects declared by their torque from the measured states; 0 without).  ``fs``: the model
    vector's slots of freed values (DIRECT_SLOTS or exogenous), whose sensitivities follow at [_NS + 4 j:
    _NS + 4 j + 4]; ``fe`` (len(fs), 2): the exogenous ones' per-unit torques now (0 for the others).
    ``sens`` False: the states alone (0..6 and the further lags), no sensitivity is written (a pass whose
    predictions are all its caller needs)."""
    j1, b1, j2, b2 = p[0], p[1], p[2], p[3]
    eps = FRICTION_SMOOTH_RAD_S  # the Jacobian's derivative of coulomb_sign
    g1 = reversed_gain(x[4], p[25])  # thrust asymmetry of a reversed rotor (1 without)
    g2 = reversed_gain(x[5], p[26])
    m1 = g1 * thrust(x[4], p[4], p[5], signed)
    m2 = g2 * thrust(x[5], p[6], p[7], signed)
    # the drives of the gyroscope and of M_R: M1 and tau1 (eq. 1), or the voltage u1 (the bench's structure)
    # (the slots hold 0 or 1: blended, not branched, so that the compiler vectorises these kernels as before)
    gv, rv = p[GYRO_VOLTAGE_SLOT], p[REACTION_VOLTAGE_SLOT]
    gd = m1 + gv * (u1 - m1)
    rd = x[4] + rv * (u1 - x[4])
    mr = reaction_moment(rd, x[6], p[16], p[17], p[18])
    sa, ca = math.sin(x[0]), math.cos(x[0])
    # gravity Mg sin(alpha + delta): delta, a centre-of-mass offset (0 in the seed model)
    dg = p[GRAVITY_OFFSET_SLOT]
    sg, cg = (sa, ca) if dg == 0.0 else (math.sin(x[0] + dg), math.cos(x[0] + dg))
    # the rates' smoothed signs (a tanh each: an eighth of a pass) only where a Coulomb friction acts: every term
    # that reads them is multiplied by it (a freed one's sensitivity takes its own: _direct)
    th1 = coulomb_sign(x[1]) if p[20] != 0.0 else 0.0
    th2 = coulomb_sign(x[3]) if p[21] != 0.0 else 0.0
    fr1 = friction(th1, x[1], p[20], p[22])  # friction beyond B: Coulomb (smoothed) and drag
    fr2 = friction(th2, x[3], p[21], p[23])
    dj = p[YAW_INERTIA_SLOT]  # a yaw inertia J2 - dJ sin^2(alpha) (0 in the seed model)
    j2e = yaw_inertia(j2, dj, sa)
    f1 = (pitch_torque(m1, gd, sg, ca, x[3], p[8], p[9]) - b1 * x[1] + fr1 + e1) / j1  # eq. (1), pitch
    f3 = (yaw_torque(m2, mr) - b2 * x[3] - p[24] * x[2] + fr2 + e2) / j2e  # eq. (1), yaw (a cable: -k beta)
    if dj != 0.0:
        f1 += centrifugal_pitch(dj, sa, ca, x[3]) / j1
        f3 += coriolis_yaw(dj, sa, ca, x[1], x[3]) / j2e
    d[0] = x[1]
    d[1] = f1
    d[2] = x[3]
    d[3] = f3
    d[4] = motor_rate(_drive(u1, x[_LAG], p[LAG1_SLOT]), x[4], p[10], p[12], p[13])
    d[5] = motor_rate(_drive(u2, x[_LAG + 1], p[LAG2_SLOT]), x[5], p[11], p[14], p[15])
    d[6] = lag_rate(rd, x[6], p[18])
    d[_LAG] = _lag_drive_rate(u1, x[_LAG], p[LAG1_SLOT])
    d[_LAG + 1] = _lag_drive_rate(u2, x[_LAG + 1], p[LAG2_SLOT])
    if not sens:
        return
    # the Jacobian A: pitch row (alpha'') and yaw row (beta''); alpha'' does not depend on beta, and beta'' depends
    # on alpha and alpha' only through the yaw inertia's terms
    a10 = (-p[8] * cg + p[9] * gd * x[3] * sa) / j1
    a11 = (-b1 - p[20] * (1.0 - th1 * th1) / eps - 2.0 * p[22] * abs(x[1])) / j1
    a13 = -p[9] * gd * ca / j1
    b12 = -p[24] / j2e
    b13 = (-b2 - p[21] * (1.0 - th2 * th2) / eps - 2.0 * p[23] * abs(x[3])) / j2e
    b10 = b11 = 0.0
    if dj != 0.0:
        c2a = ca * ca - sa * sa  # d(sin cos)/d alpha
        dsc2 = 2.0 * dj * sa * ca  # -d(yaw inertia)/d alpha
        a10 -= dj * c2a * x[3] * x[3] / j1
        a13 -= dsc2 * x[3] / j1
        b10 = (2.0 * dj * c2a * x[1] * x[3] + dsc2 * f3) / j2e  # and through J(alpha)'s own slope
        b11 = dsc2 * x[3] / j2e
        b13 += dsc2 * x[1] / j2e
    # direct terms: J/B, then the start states through the thrusts and M_R
    p1, p2 = p[13] / p[12], p[15] / p[14]
    df1_t1 = g1 * thrust_slope(x[4], p[4], p[5], signed) * (1.0 - (1.0 - gv) * p[9] * x[3] * ca) / j1
    df3_t1 = -(1.0 - rv) * p[16] * p[17] / p[18] / j2e
    df3_z = -p[16] * (1.0 - p[17] / p[18]) / j2e
    df3_t2 = g2 * thrust_slope(x[5], p[6], p[7], signed) / j2e
    for c in range(NU):
        i = _S0 + 4 * c
        d[i] = x[i + 1]
        d[i + 1] = a10 * x[i] + a11 * x[i + 1] + a13 * x[i + 3]
        d[i + 2] = x[i + 3]
        d[i + 3] = b10 * x[i] + b11 * x[i + 1] + b12 * x[i + 2] + b13 * x[i + 3]
    for c in range(fs.size):  # freed model values: the same A, their own direct terms
        i = _NS + 4 * c
        q1, q3 = _direct(fs[c], x, p, signed, g1, g2, m1, gd, rd, sg, cg, sa, ca, f3, fe[c, 0], fe[c, 1])
        d[i] = x[i + 1]
        d[i + 1] = a10 * x[i] + a11 * x[i + 1] + a13 * x[i + 3] + q1 / j1
        d[i + 2] = x[i + 3]
        d[i + 3] = b10 * x[i] + b11 * x[i + 1] + b12 * x[i + 2] + b13 * x[i + 3] + q3 / j2e
    d[_S0 + 1] -= f1 / j1  # J1
    d[_S0 + 4 + 1] -= x[1] / j1  # B1
    d[_S0 + 8 + 3] -= f3 / j2e  # J2
    d[_S0 + 12 + 3] -= x[3] / j2e  # B2
    st1, st2, sz1, sz0 = x[_MS], x[_MS + 1], x[_MS + 2], x[_MS + 3]
    d[_S0 + 16 + 1] += df1_t1 * st1  # tau1(0): through M1, and M_R's direct and lagged paths
    d[_S0 + 16 + 3] += df3_t1 * st1 + df3_z * sz1
    d[_S0 + 20 + 3] += df3_t2 * st2  # tau2(0)
    d[_S0 + 24 + 3] += df3_z * sz0  # zeta(0)
    # the motors' sensitivities decay with the motors' own poles
    d[_MS] = -p1 * st1
    d[_MS + 1] = -p2 * st2
    d[_MS + 2] = ((1.0 - rv) * st1 - sz1) / p[18]
    d[_MS + 3] = -sz0 / p[18]
    _lag_start_rates(x, _LS, p, d)


@njit(cache=True, nogil=True, fastmath={"contract", "reassoc", "arcp"}, inline="always")
def _lag_start_rates(x, i, p, d):
    """The further lags' start-state sensitivities at x[i:i + 5] (layout above): d lag1/d lag1(0), d tau1/d lag1(0),
    d zeta/d lag1(0), d lag2/d lag2(0), d tau2/d lag2(0), each decaying with its own lag (0 when its T2 is 0)."""
    l1 = x[i] if p[LAG1_SLOT] > 0.0 else 0.0
    l2 = x[i + 3] if p[LAG2_SLOT] > 0.0 else 0.0
    d[i] = -l1 / p[LAG1_SLOT] if p[LAG1_SLOT] > 0.0 else 0.0
    d[i + 1] = (p[10] * l1 - p[13] * x[i + 1]) / p[12]
    # M_R's lag follows tau1's sensitivity in eq. (1), none under a voltage-driven reaction (the slot holds 1):
    # blended, not branched (as _motor_rhs)
    d[i + 2] = ((1.0 - p[REACTION_VOLTAGE_SLOT]) * x[i + 1] - x[i + 2]) / p[18]
    d[i + 3] = -l2 / p[LAG2_SLOT] if p[LAG2_SLOT] > 0.0 else 0.0
    d[i + 4] = (p[11] * l2 - p[15] * x[i + 4]) / p[14]


@njit(cache=True, nogil=True, fastmath={"contract", "reassoc", "arcp"}, **HELPER)
def _rk4(x, xt, k1, k2, k3, k4, v1, v2, e1, e2, p, signed, dur, max_sub, fs, fe, sens=True):
    """Advance x (with its sensitivities) by dur [s] with the voltages v1, v2 and exogenous torques e1, e2 held,
    RK4 sub-steps <= max_sub; fs, fe, sens: see _rhs (sens False: only the states 0..6 and the further lags
    move, by the same arithmetic)."""
    nsub = max(1, int(math.ceil(dur / max_sub - 1e-9)))
    hs = dur / nsub
    stops = p[STOP_SLOT] < p[STOP_SLOT + 1] or p[STOP_SLOT + 2] < p[STOP_SLOT + 3]
    for _ in range(nsub):
        _rhs(x, v1, v2, e1, e2, p, signed, k1, fs, fe, sens)
        _stage(xt, x, 0.5 * hs, k1, sens)
        _rhs(xt, v1, v2, e1, e2, p, signed, k2, fs, fe, sens)
        _stage(xt, x, 0.5 * hs, k2, sens)
        _rhs(xt, v1, v2, e1, e2, p, signed, k3, fs, fe, sens)
        _stage(xt, x, hs, k3, sens)
        _rhs(xt, v1, v2, e1, e2, p, signed, k4, fs, fe, sens)
        for i in range(x.size if sens else _LAG + 2):
            if sens or i < 7 or i >= _LAG:
                x[i] += hs / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        if stops:  # the end stops of the bench's structure, out of the hot path (a call only when there are some)
            _at_stops(x, k1, k2, k3, k4, hs, v1, v2, e1, e2, p, signed, fs, fe, sens)


@njit(cache=True, nogil=True, fastmath={"contract", "reassoc", "arcp"}, **HELPER)
def _at_stops(x, k1, k2, k3, k4, hs, v1, v2, e1, e2, p, signed, fs, fe, sens):
    """After an RK4 sub-step of hs [s] (its stages k1..k4): each angle past an end stop and still moving into it
    (none when low >= high) is held at the stop, from the moment within the sub-step it reached it (linear between
    the sub-step's ends) or all of it when it rested there already, and let go where the torques point away."""
    for a in range(2):
        lo, hi = p[STOP_SLOT + 2 * a], p[STOP_SLOT + 2 * a + 1]
        j = 2 * a
        if lo < hi and ((x[j] <= lo and x[j + 1] <= 0.0) or (x[j] >= hi and x[j + 1] >= 0.0)):
            before = x[j] - hs / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])  # the angle the sub-step began at
            edge = lo if x[j] <= lo else hi
            left = hs  # the time at the stop within this sub-step
            if (edge == lo and before > lo) or (edge == hi and before < hi):
                left = hs * (edge - x[j]) / (before - x[j])
            _stop(x, j, edge, sens, fs.size)
            # what the torques do there for the rest of the sub-step: pointing away, they lift it off
            _rhs(x, v1, v2, e1, e2, p, signed, k1, fs, fe, False)
            acc = k1[j + 1]
            if (edge == lo and acc > 0.0) or (edge == hi and acc < 0.0):
                x[j] = edge + 0.5 * acc * left * left
                x[j + 1] = acc * left


@njit(cache=True, nogil=True, fastmath={"contract", "reassoc", "arcp"}, inline="always")
def _stop(x, i, edge, sens, nf):
    """An angle (x[i], its rate x[i + 1]) at an end stop ``edge`` [rad] (model/structure.py), as Simulink's
    Second-Order Integrator with position limits holds it: the angle set to the stop and its rate to zero (an
    inelastic stop; _rk4 places the moment of impact within the sub-step and lets the angle go where the torques
    point away).  Held there, the angle depends on no unknown: its and its rate's sensitivities are zero."""
    x[i] = edge
    x[i + 1] = 0.0
    if sens:
        for c in range(NU):
            x[_S0 + 4 * c + i] = 0.0
            x[_S0 + 4 * c + i + 1] = 0.0
        for c in range(nf):
            x[_NS + 4 * c + i] = 0.0
            x[_NS + 4 * c + i + 1] = 0.0


@njit(cache=True, nogil=True, fastmath={"contract", "reassoc", "arcp"}, inline="always")
def _stage(xt, x, a, k, sens):
    """xt = x + a k, on every state or (sens False) on the states 0..6 and the further lags alone."""
    for i in range(x.size if sens else _LAG + 2):
        if sens or i < 7 or i >= _LAG:
            xt[i] = x[i] + a * k[i]


@njit(cache=True, nogil=True, fastmath={"contract", "reassoc", "arcp"}, **HELPER)
def _pieces(k, u1, u2, h, dsw):
    """The voltages held over sample interval k, each switching at its own time: up to three pieces, cut where
    u1 and u2 switch.  Returns the cut times [s] and, per piece, the voltages."""
    d1, d2 = (dsw[k, 0], dsw[k, 1]) if k > 0 else (0.0, 0.0)
    lo, hi = min(d1, d2), max(d1, d2)
    cuts = (0.0, lo, hi, h[k])
    v1 = (u1[k] if 0.0 >= d1 else u1[k - 1], u1[k] if lo >= d1 else u1[k - 1], u1[k] if hi >= d1 else u1[k - 1])
    v2 = (u2[k] if 0.0 >= d2 else u2[k - 1], u2[k] if lo >= d2 else u2[k - 1], u2[k] if hi >= d2 else u2[k - 1])
    return cuts, v1, v2


@njit(cache=True, nogil=True, fastmath={"contract", "reassoc", "arcp"}, **HELPER)
def _motor_rhs(x, u1, u2, p, d):
    """The motor lags and M_R's lag state of eq. (1) with their sensitivities to the start states, and the
    further lags of second-order motors with theirs: the layout's states 4, 5, 6, 51..54, 55, 56, 57..61 as
    x[0..13] (the same formulas as _rhs; they depend on no J/B or angle)."""
    d[0] = motor_rate(_drive(u1, x[7], p[LAG1_SLOT]), x[0], p[10], p[12], p[13])
    d[1] = motor_rate(_drive(u2, x[8], p[LAG2_SLOT]), x[1], p[11], p[14], p[15])
    # M_R's lag driven by tau1 (eq. 1) or by u1 itself (the bench's structure: the slot holds 1), blended without a
    # branch: a test of the slot in these loops made motor_starts three times slower (no longer vectorised)
    rv = p[REACTION_VOLTAGE_SLOT]
    d[2] = lag_rate(x[0] + rv * (u1 - x[0]), x[2], p[18])
    d[3] = -p[13] / p[12] * x[3]
    d[4] = -p[15] / p[14] * x[4]
    d[5] = ((1.0 - rv) * x[3] - x[5]) / p[18]
    d[6] = -x[6] / p[18]
    d[7] = _lag_drive_rate(u1, x[7], p[LAG1_SLOT])
    d[8] = _lag_drive_rate(u2, x[8], p[LAG2_SLOT])
    _lag_start_rates(x, 9, p, d)


#: motor_starts' sensitivity states (to the start states), flushed to 0 once they have died out
_SENSITIVITIES = (3, 4, 5, 6, 9, 10, 11, 12, 13)


@njit(cache=True, nogil=True, fastmath={"contract", "reassoc", "arcp"})
def motor_starts(u1, u2, p, h, dsw, max_sub, win, nw, m0):
    """(nw, 14) motor states and their start-state sensitivities (layout states 4, 5, 6, 51..54), the further
    lags' states (55, 56) and their start-state sensitivities (57..61) at each window's first sample, integrated
    through the log from m0 = tau1(0), tau2(0), zeta(0), lag1(0), lag2(0) with the same RK4 sub-steps as the full
    pass.  They depend on no J/B or angle, so the windows can then be integrated independently."""
    out = np.zeros((nw, 14))
    x = np.zeros(14)
    xt = np.empty(14)
    k1 = np.empty(14)
    k2 = np.empty(14)
    k3 = np.empty(14)
    k4 = np.empty(14)
    x[0], x[1], x[2] = m0[0], m0[1], m0[2]
    x[3], x[4], x[6] = 1.0, 1.0, 1.0
    x[7], x[8] = m0[3], m0[4]
    x[9], x[12] = 1.0, 1.0
    for w in range(nw):
        for i in _SENSITIVITIES:  # the start states' influence has died out: exactly 0, never subnormal numbers
            if abs(x[i]) < 1e-200:  # (whose arithmetic is ~100x slower: an hour took 62 s instead of 5 s)
                x[i] = 0.0
        out[w] = x
        if w == nw - 1:
            break
        for k in range(w * win, (w + 1) * win):
            cuts, v1, v2 = _pieces(k, u1, u2, h, dsw)
            for j in range(3):
                dur = cuts[j + 1] - cuts[j]
                if dur <= 0.0:
                    continue
                nsub = max(1, int(math.ceil(dur / max_sub - 1e-9)))
                hs = dur / nsub
                for _ in range(nsub):
                    _motor_rhs(x, v1[j], v2[j], p, k1)
                    for i in range(14):
                        xt[i] = x[i] + 0.5 * hs * k1[i]
                    _motor_rhs(xt, v1[j], v2[j], p, k2)
                    for i in range(14):
                        xt[i] = x[i] + 0.5 * hs * k2[i]
                    _motor_rhs(xt, v1[j], v2[j], p, k3)
                    for i in range(14):
                        xt[i] = x[i] + hs * k3[i]
                    _motor_rhs(xt, v1[j], v2[j], p, k4)
                    for i in range(14):
                        x[i] += hs / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    return out


_MOTOR = (4, 5, 6, _MS, _MS + 1, _MS + 2, _MS + 3, _LAG, _LAG + 1, _LS, _LS + 1, _LS + 2, _LS + 3, _LS + 4)
#: the model values the motor states depend on (k1, k2, T11, T10, T21, T20, Tp, the further lags): keys of the
#: motor cache
_MOTOR_P = np.array([_P.index(k) for k in ("k1", "k2", "T11", "T10", "T21", "T20", "Tp")] +
                    [LAG1_SLOT, LAG2_SLOT, REACTION_VOLTAGE_SLOT])


@njit(cache=True, nogil=True, fastmath={"contract", "reassoc", "arcp"})
def windows_pass(u1, u2, y, inv_sig, starts, mstart, p, signed, h, dsw, max_sub, win, block, ext, fs, tq, quanta,
                 grids, sens, w0, w1, out, extra, costs, a_mat, b_vec, scores, b_grid, scores_grid):
    """Windows w0..w1-1 of one pass: predictions (out), each window's weighted cost (costs), normal equations
    (a_mat, b_vec) and its blocks' scores, written into the caller's arrays (disjoint slices: windows can run
    in threads).  Each window starts from its fitted angles and rates (starts) and the motor states of
    motor_starts (mstart).  ``ext`` (n, 2): exogenous torques [N m] held over each sample interval, or (0, 2)
    for none.  ``fs``: slots of freed model values with exact sensitivities (columns NU.. of the normal
    equations, then those of ``extra``); ``tq`` (n, 2, m): the exogenous torques per unit parameter, held like
    ``ext`` (slot _NP + j reads tq[:, :, j]).  ``grids`` (r, 2): encoder grids, the places of their zeros [rad]
    for alpha, beta, with ``quanta`` (2,) [rad] (0: that angle is not rounded): for each, the right-hand sides
    (b_grid, (windows, r, unknowns)) and block scores (scores_grid, (r, blocks, unknowns)) of a residual that is
    the prediction's own rounding on that grid, rounded - predicted (numerics/quantization.py); (0, 2): none."""
    n = u1.size
    has_ext = ext.shape[0] > 0
    nw = starts.shape[0]
    nb = scores.shape[0]
    nf = fs.size
    offset = p[SENSOR_OFFSET_SLOT]
    m = extra.shape[2]
    nt = NU + nf + m
    ns = _NS + 4 * nf
    x = np.zeros(ns)
    xt = np.empty(ns)
    k1 = np.empty(ns)
    k2 = np.empty(ns)
    k3 = np.empty(ns)
    k4 = np.empty(ns)
    fe = np.zeros((nf, 2))
    ja = np.empty(nt)
    jb = np.empty(nt)
    ngr = grids.shape[0]
    for w in range(w0, w1):
        s = w * win
        e = n if w == nw - 1 else s + win
        for i in range(ns):  # the angles restart: their sensitivities are relative to this window's start
            x[i] = 0.0
        for i in range(14):
            x[_MOTOR[i]] = mstart[w, i]
        x[0], x[1], x[2], x[3] = starts[w, 0], starts[w, 1], starts[w, 2], starts[w, 3]
        for j in range(4):  # d (alpha, alpha', beta, beta') / d (alpha0, alpha'0, beta0, beta'0) = identity
            x[_S0 + 4 * (NG + j) + j] = 1.0
        cost = 0.0
        for k in range(s, e):
            out[k, 0] = x[0] + offset  # the logged pitch: the true angle plus the encoder's zero offset
            out[k, 1] = x[2]
            ra = (y[k, 0] - out[k, 0]) * inv_sig[0]
            rb = (y[k, 1] - x[2]) * inv_sig[1]
            cost += ra * ra + rb * rb
            if sens:  # the normal equations (sens False: predictions and cost only, they stay zero)
                for c in range(NU):
                    ja[c] = x[_S0 + 4 * c] * inv_sig[0]
                    jb[c] = x[_S0 + 4 * c + 2] * inv_sig[1]
                for c in range(nf):
                    ja[NU + c] = (x[_NS + 4 * c] + (1.0 if fs[c] == SENSOR_OFFSET_SLOT else 0.0)) * inv_sig[0]
                    jb[NU + c] = x[_NS + 4 * c + 2] * inv_sig[1]
                for c in range(m):
                    ja[NU + nf + c] = extra[k, 0, c] * inv_sig[0]
                    jb[NU + nf + c] = extra[k, 1, c] * inv_sig[1]
                q = min(k // block, nb - 1)
                for i in range(nt):
                    g = ja[i] * ra + jb[i] * rb
                    b_vec[w, i] += g
                    scores[q, i] += g
                    ai, bi = ja[i], jb[i]
                    # every row whole (the compiler vectorises a full row, not a triangle's: a pass 8-11 % faster);
                    # the lower triangle is then overwritten with the upper's values below, as before
                    for j in range(nt):
                        a_mat[w, i, j] += ai * ja[j] + bi * jb[j]
                for r in range(ngr):  # the residual each encoder grid would leave: the prediction's rounding error
                    ea, eb = 0.0, 0.0
                    if quanta[0] > 0.0:
                        v = out[k, 0] - grids[r, 0]
                        ea = (quanta[0] * math.floor(v / quanta[0] + 0.5) - v) * inv_sig[0]
                    if quanta[1] > 0.0:
                        v = out[k, 1] - grids[r, 1]
                        eb = (quanta[1] * math.floor(v / quanta[1] + 0.5) - v) * inv_sig[1]
                    for i in range(nt):
                        g = ja[i] * ea + jb[i] * eb
                        b_grid[w, r, i] += g
                        scores_grid[r, q, i] += g
            if k == e - 1:
                break
            # hold the voltages over the actual interval, each switching at its own time
            cuts, v1, v2 = _pieces(k, u1, u2, h, dsw)
            e1, e2 = (ext[k, 0], ext[k, 1]) if has_ext else (0.0, 0.0)
            for c in range(nf):
                if fs[c] >= _NP:
                    fe[c, 0], fe[c, 1] = tq[k, 0, fs[c] - _NP], tq[k, 1, fs[c] - _NP]
            for j in range(3):
                dur = cuts[j + 1] - cuts[j]
                if dur > 0.0:
                    _rk4(x, xt, k1, k2, k3, k4, v1[j], v2[j], e1, e2, p, signed, dur, max_sub, fs, fe, sens)
        costs[w] = cost
        for i in range(nt):
            for j in range(i):
                a_mat[w, i, j] = a_mat[w, j, i]


#: logs shorter than this many samples run their windows in one thread.  The pool (numerics.parallel) lives as
#: long as the process, so a pass pays a hand-off (~0.1 ms), not a thread's start: a 90 s log at 250 Hz (22 500
#: samples, 21 ms a pass, thousands of passes in diagnose) had run on one core under the earlier 50 000
THREAD_MIN_SAMPLES = 4_000


def motor_response(free, m0):
    """motor_starts from the start states m0 (tau1(0), tau2(0), zeta(0), lag1(0), lag2(0)), given its result from
    zero start states (``free``): the motors' equations are linear in their start states and the sensitivity
    columns are their coefficients."""
    ms = free.copy()
    ms[:, 0] += free[:, 3] * m0[0] + free[:, 10] * m0[3]
    ms[:, 1] += free[:, 4] * m0[1] + free[:, 13] * m0[4]
    ms[:, 2] += free[:, 5] * m0[0] + free[:, 6] * m0[2] + free[:, 11] * m0[3]
    ms[:, 7] += free[:, 9] * m0[3]
    ms[:, 8] += free[:, 12] * m0[4]
    return ms


def gauss_newton_pass(u1, u2, y, inv_sig, starts, m0, p, signed, h, dsw, max_sub, win, block, out, extra,
                      motor_free=None, ext=None, fs=None, tq=None, rounding=None, sens=True):
    """One pass over the log: predictions (out), weighted cost, per-window normal equations in the
    NU unknowns (J1, B1, J2, B2, tau1(0), tau2(0), zeta(0), alpha0, alpha'0, beta0, beta'0), then one per
    slot in ``fs`` (freed model values, DIRECT_SLOTS or exogenous: exact forward sensitivities; ``tq`` (n, 2, m)
    the exogenous torques per unit parameter), then one per column of ``extra`` (n, 2, m: sensitivities of
    alpha, beta to further freed values, computed by the caller), and per-block scores.  ``h``: the n - 1 sample intervals [s]; each is integrated in RK4
    sub-steps <= max_sub.  ``dsw`` (n, 2): u1[k], u2[k] take effect dsw[k] [s] after sample k (before that the
    previous voltage holds); zeros when every voltage acts from its own stamp.

    ``m0``: the motors' start states tau1(0), tau2(0), zeta(0), lag1(0), lag2(0) (motor_response).  The motor
    states at each window's start come first (motor_starts); the windows are then independent and run on up to
    parallel.cores() cores (one inside parallel.fan_out), each window computed the same way whatever the split,
    so the numbers do not depend on the machine.  ``motor_free``: motor_starts from zero start states for this p
    (computed when None).  ``ext`` (n, 2): exogenous torques [N m] held over each sample interval (None: none).
    ``rounding``: (quanta (2,) [rad], grids (r, 2) [rad]) for windows_pass, whose b_grid and scores_grid are then
    returned after the scores.  ``sens`` False: the predictions and the cost alone (the normal equations and scores
    come back zero), at a fraction of the pass (no sensitivity is integrated)."""
    u1, u2 = readonly(u1), readonly(u2)  # one compiled windows_pass and motor_starts (kernel_args)
    n = u1.size
    nw = starts.shape[0]
    nb = max(n // block, 1)
    fs = np.zeros(0, dtype=np.int64) if fs is None else np.asarray(fs, dtype=np.int64)
    tq = np.zeros((0, 2, 0)) if tq is None else tq
    nt = NU + fs.size + extra.shape[2]
    costs = np.zeros(nw)
    a_mat = np.zeros((nw, nt, nt))
    b_vec = np.zeros((nw, nt))
    scores = np.zeros((nb, nt))
    quanta, grids = (np.zeros(2), np.zeros((0, 2))) if rounding is None else map(np.asarray, rounding)
    b_grid = np.zeros((nw, grids.shape[0], nt))
    scores_grid = np.zeros((grids.shape[0], nb, nt))
    if motor_free is None:
        motor_free = motor_starts(u1, u2, p, h, dsw, max_sub, win, nw, np.zeros(5))
    mstart = motor_response(motor_free, m0)
    args = (u1, u2, y, inv_sig, starts, mstart, p, signed, h, dsw, max_sub, win, block,
            np.zeros((0, 2)) if ext is None else ext, fs, tq, quanta, grids, bool(sens))
    tail = (out, extra, costs, a_mat, b_vec, scores, b_grid, scores_grid)
    groups = min(parallel.cores(), nw) if n >= THREAD_MIN_SAMPLES and not parallel.in_worker() else 1
    if groups <= 1:
        windows_pass(*args, 0, nw, *tail)
    else:
        cut = [round(g * nw / groups) for g in range(groups + 1)]
        pool = parallel.pool(groups - 1)
        jobs = [pool.submit(windows_pass, *args, cut[g], cut[g + 1], *tail) for g in range(1, groups)]
        windows_pass(*args, cut[0], cut[1], *tail)
        for j in jobs:
            j.result()
    if rounding is not None:
        return float(costs.sum()), a_mat, b_vec, scores, b_grid, scores_grid
    return float(costs.sum()), a_mat, b_vec, scores


def warm_up() -> None:
    """Load the compiled kernel from numba's cache on a tiny input (commands call this in a thread)."""
    from ..params import defaults

    n = 8
    u = np.zeros(n)
    gauss_newton_pass(u, u, np.zeros((n, 2)), np.ones(2), np.zeros((1, 4)), np.zeros(5), model_vector(defaults()),
                      False, np.full(n - 1, 1e-3), np.zeros((n, 2)), MAX_SUBSTEP_S, n, n, np.empty((n, 2)),
                      np.zeros((n, 2, 0)))


def _start_velocity(x: np.ndarray, t: np.ndarray, s: int) -> float:
    """Slope [rad/s] of a quadratic fitted to the first 50 ms (at least 5 samples) of a window."""
    dt = float(np.median(np.diff(t[s:s + 8]))) if t.size - s > 2 else 1.0
    m = min(max(5, int(round(0.05 / dt))), x.size - s)
    if m < 3:
        return 0.0
    coef = safe.polyfit(t[s:s + m] - t[s], x[s:s + m], 2)
    return float(coef[1]) if coef is not None else math.nan


def substeps(dt: float, max_sub: float = MAX_SUBSTEP_S) -> int:
    """RK4 sub-steps per sample interval of dt [s], each at most ``max_sub`` [s]."""
    return max(1, int(math.ceil(dt / max_sub - 1e-9)))


def schur(a, b, ng=NG):
    """Eliminate each window's start: the global unknowns' normal matrix and right-hand side, and per window
    (L'L)^-1 [L'G, L'r], from which the starts' step and the projected scores follow.  The first ``ng``
    unknowns are global, the next NL per window."""
    s_mat, s_rhs, per_window = np.zeros((ng, ng)), np.zeros(ng), []
    for w in range(a.shape[0]):
        lg = a[w, ng:, :ng]
        k_mat = safe.lstsq(a[w, ng:, ng:], np.column_stack([lg, b[w, ng:]]), rcond=1e-13)
        s_mat += a[w, :ng, :ng] - lg.T @ k_mat[:, :ng]
        s_rhs += b[w, :ng] - lg.T @ k_mat[:, ng]
        per_window.append(k_mat)
    return s_mat, s_rhs, per_window


def batch_covariance(s_mat, per_window, scores, win, block):
    """Batch-means covariance of the global unknowns: per-block scores with the windows' starts projected out."""
    ng = s_mat.shape[0]
    nb = scores.shape[0]
    w_of_block = np.minimum(np.arange(nb) * block // win, len(per_window) - 1)
    proj = np.stack([k[:, :ng] for k in per_window])[w_of_block]  # (nb, NL, ng)
    sc = scores[:, :ng] - np.einsum("bij,bi->bj", proj, scores[:, ng:])
    sc = sc - sc.mean(axis=0)
    meat = nb / max(nb - 1, 1) * sc.T @ sc
    inv = scaled_inverse(s_mat)
    return inv @ meat @ inv


def scaled_inverse(s_mat):
    d = np.sqrt(np.maximum(np.diag(s_mat), 1e-300))
    return safe.pinv(s_mat / np.outer(d, d), rcond=1e-13) / np.outer(d, d)


#: model-vector slots whose sensitivities the kernel integrates exactly (_direct): every known value but the
#: motors' (k1, k2, T11, T10, T21, T20, Tp act through the motor states, which run on through the whole log and
#: are integrated before the windows: theirs are forward differences), every effect slot (not the further lags of
#: LAG_SLOTS: a second-order motor's value is profiled, never freed here) and every exogenous torque's parameter
#: (slots from _NP on)
DIRECT_SLOTS = frozenset([_P.index(k) for k in ("a1", "b1", "a2", "b2", "Mg", "Kg", "kc", "T0")] +
                         list(range(GRAVITY_OFFSET_SLOT, LAG1_SLOT)))


def _exact(i: int) -> bool:
    return i in DIRECT_SLOTS or i >= _NP or i in _LAG_START_SLOT_SET


_LAG_START_SLOT_SET = frozenset(LAG_START_SLOTS.values())


#: an input saturation's level (effect key -> a slot of its own below 0: it is no model-vector value).  The
#: kernel's voltages are clipped at it before the motors (u = clip(u_logged, -U, U)); when it is freed its
#: sensitivity is a forward difference like the motors' values (d u / d U = sign(u) on the clipped samples, through
#: the motor lags).  A saturation acting on most samples has a minimum 0.02 % wide in U (a yaw driven at +-U
#: integrates any thrust error): a profile over U with a few Gauss-Newton steps per trial stopped 0.05 % off it
#: and left the yaw at 5x its floor; Gauss-Newton over U with J/B and the start states converges onto it
SATURATION_SLOTS = {"input_saturation:pitch": -1, "input_saturation:yaw": -2}
#: a shifted dead zone's width (model/effects.py: u - w sign(u) outside [-w, w], 0 inside), likewise: applied to the
#: voltages before the saturation, its width a Gauss-Newton unknown when freed (d u / d w = -sign(u) outside the
#: zone, as a forward difference).  Two motors' widths profiled one at a time, each with the other held where a fit
#: without it put it, stay a few per cent off and leave the model above its floor (measured on the textbook plant:
#: 0.207 and 0.249 V for 0.215 and 0.262 V); fitted together with J/B they are not
SHIFT_SLOTS = {"shifted_dead_zone:pitch": -5, "shifted_dead_zone:yaw": -6}
#: the voltage transforms the kernel's inputs go through (slot -> its place in _Problem.levels)
INPUT_SLOTS = {**SATURATION_SLOTS, **SHIFT_SLOTS}
_INPUT_PLACE = {-1: 0, -2: 1, -5: 2, -6: 3}
_INPUT_SLOT_SET = frozenset(INPUT_SLOTS.values())
#: no saturation, no dead zone
_NO_TRANSFORM = (math.inf, math.inf, 0.0, 0.0)


@dataclass
class _Problem:
    """One log and model, evaluated at any parameters: the kernel pass with the freed values' sensitivities
    (exact for DIRECT_SLOTS and exogenous torques, forward differences for the motors' values)."""
    u1: np.ndarray  # the voltages [V], read-only (kernel_args: one compiled motor_starts and windows_pass)
    u2: np.ndarray
    y: np.ndarray
    inv_sig: np.ndarray
    base: np.ndarray
    signed: bool
    h: np.ndarray
    dsw: np.ndarray  # (n, 2) voltage switch delays after each stamp [s]
    win: int
    block: int
    free_idx: list  # positions in the model vector of the freed known values (then the lag starts' LAG_START_SLOTS)
    motor_cache: dict = field(default_factory=dict)  # (max_sub, motor values) -> motor_starts from zero states
    #: (n, 2, m) exogenous torques per unit parameter [N m / unit], held over each sample interval; their
    #: parameters sit after _NP in the model vector (model_vector's ``exogenous``)
    torques: np.ndarray | None = None
    #: saturation levels and shifted dead zones' widths held [V] (INPUT_SLOTS' slot -> value); a freed one's value
    #: is in theta instead
    clips: dict = field(default_factory=dict)
    max_sub: float = MAX_SUBSTEP_S  # the RK4 sub-step's upper bound [s] (COULOMB_SUBSTEP_S with a friction)
    _clipped: dict = field(default_factory=dict)  # (pitch, yaw levels) -> the clipped voltages (a few kept)
    #: the further lags' start states [V] where they are not unknowns (their T2 is 0: they act on nothing)
    lag0: tuple = (0.0, 0.0)

    def motor0(self, th) -> np.ndarray:
        """The motors' start states at th: tau1(0), tau2(0), zeta(0), lag1(0), lag2(0)."""
        m0 = np.r_[th[4:NG], self.lag0]
        for j, i in enumerate(self.free_idx):
            if i in _LAG_START_SLOT_SET:
                m0[-i] = th[NG + j]  # slot -3: lag1(0), m0[3]; -4: lag2(0), m0[4]
        return m0

    def levels(self, th) -> tuple[float, float, float, float]:
        """The main and tail motors' saturation levels [V] (inf: none) and shifted dead zones' widths [V] (0: none)
        at th."""
        lv = list(_NO_TRANSFORM)
        for i, v in self.clips.items():
            lv[_INPUT_PLACE[i]] = abs(v)
        for j, i in enumerate(self.free_idx):
            if i in _INPUT_SLOT_SET:
                lv[_INPUT_PLACE[i]] = abs(float(th[NG + j]))
        return lv[0], lv[1], lv[2], lv[3]

    def inputs(self, th) -> tuple[np.ndarray, np.ndarray]:
        """The voltages the motors see at th: the logged ones through the shifted dead zones, then clipped at the
        saturation levels."""
        lv = self.levels(th)
        if lv == _NO_TRANSFORM:
            return self.u1, self.u2
        if lv not in self._clipped:
            if len(self._clipped) >= 4:  # a Gauss-Newton iteration asks for two (the point, its difference)
                self._clipped.pop(next(iter(self._clipped)))
            out = []
            for u, limit, width in ((self.u1, lv[0], lv[2]), (self.u2, lv[1], lv[3])):
                if width > 0.0:
                    u = np.sign(u) * np.maximum(np.abs(u) - width, 0.0)
                if not math.isinf(limit):
                    u = np.clip(u, -limit, limit)
                out.append(u if u is self.u1 or u is self.u2 else readonly(u))
            self._clipped[lv] = tuple(out)
        return self._clipped[lv]

    @property
    def differenced(self) -> list:
        """The freed values whose sensitivities are forward differences (one more pass each)."""
        return [i for i in self.free_idx if not _exact(i)]

    def vector(self, th):
        """The kernel's model vector at th: J/B and the freed values over the table/file values."""
        pv = self.base.copy()
        pv[:4] = th[:4]
        for j, i in enumerate(self.free_idx):
            if i >= 0:  # (a saturation's level is no model value: inputs)
                pv[i] = th[NG + j]
        return pv

    def exogenous(self, pv):
        """(n, 2) torques [N m] of the exogenous effects at the model vector's values, or None without any."""
        if self.torques is None or not np.any(pv[_NP:]):
            return None
        return np.ascontiguousarray(self.torques @ pv[_NP:])

    def _pass(self, pv, th, st, out, max_sub, extra, exact=(), rounding=None, sens=True):
        ext = np.zeros((self.y.shape[0], 2, 0)) if extra is None else extra
        u1, u2 = self.inputs(th)
        # the motor states depend on the motors' values and voltages alone
        key = (max_sub, pv[_MOTOR_P].tobytes(), self.levels(th))
        if key not in self.motor_cache:
            self.motor_cache[key] = motor_starts(u1, u2, pv, self.h, self.dsw, max_sub, self.win,
                                                 st.shape[0], np.zeros(5))
        return gauss_newton_pass(u1, u2, self.y, self.inv_sig, st, self.motor0(th), pv, self.signed, self.h,
                                 self.dsw, max_sub, self.win, self.block, out, ext, self.motor_cache[key],
                                 self.exogenous(pv), np.array(exact, dtype=np.int64), self.torques, rounding, sens)

    def columns(self, th, st, pred, idx, max_sub=None):
        """(n, 2, len(idx)) forward-difference sensitivities of alpha, beta to the model values at ``idx``."""
        max_sub = self.max_sub if max_sub is None else max_sub
        cols = np.empty((pred.shape[0], 2, len(idx)))
        tmp = np.empty_like(pred)
        for c, i in enumerate(idx):
            if i in _INPUT_SLOT_SET:  # a saturation's level or a dead zone's width: in theta
                th_c = np.array(th, dtype=float)
                j = NG + self.free_idx.index(i)
                step = 1e-6 * max(abs(th_c[j]), 1e-3)
                th_c[j] += step
                self._pass(self.vector(th_c), th_c, st, tmp, max_sub, None, sens=False)
            else:
                pv = self.vector(th)
                step = 1e-6 * max(abs(pv[i]), 1e-3)
                pv[i] += step
                self._pass(pv, th, st, tmp, max_sub, None, sens=False)
            cols[:, :, c] = (tmp - pred) / step
        return cols

    def evaluate(self, th, st, out, max_sub=None, more=(), cost_only=False, rounding=None, known=None,
                 predict_only=False):
        """Cost, normal equations and scores at th, st; predictions in ``out``.  The unknowns in the order J/B,
        start states, the freed values (free_idx's order), the model values at ``more`` (a score test's
        candidates), then each window's start.  ``cost_only``: the cost and predictions are all the caller
        needs (a line search's trial): no pass for the differenced columns, whose entries are then missing.
        ``rounding``: gauss_newton_pass's; its right-hand sides and scores per grid follow, in the same order.
        ``known``: this point's predictions from a cost_only call at the same th, st and max_sub (a line search's
        accepted trial): the differenced columns start from them instead of a pass of their own (the same pass,
        so the same numbers; a differenced fit's iteration had spent a quarter of its passes on it).
        ``predict_only``: the cost and predictions of a pass that integrates no sensitivity (the normal equations
        and scores come back zero): a last trial whose step no further one follows."""
        max_sub = self.max_sub if max_sub is None else max_sub
        if predict_only:
            return self._pass(self.vector(th), th, st, out, max_sub, None, sens=False)
        idx = list(self.free_idx) + list(more)
        exact = [i for i in idx if _exact(i)]
        diff = [i for i in idx if not _exact(i)]
        pv = self.vector(th)
        if diff:
            if known is not None and not cost_only:
                out[:] = known
            else:
                # the predictions the differences start from (and a line search's cost): no sensitivities
                res = self._pass(pv, th, st, out, max_sub, None, sens=False)
                if cost_only:
                    return res
            res = self._pass(pv, th, st, out, max_sub, self.columns(th, st, out, diff, max_sub), exact, rounding)
        else:
            res = self._pass(pv, th, st, out, max_sub, None, exact, rounding)
        if not idx:
            return res
        kernel = exact + diff  # the kernel's columns after the NU fixed ones
        perm = np.r_[0:NG, [NU + kernel.index(i) for i in idx], NG:NU]
        cost, a, b, scores, *grid = res
        return (cost, a[:, perm][:, :, perm], b[:, perm], scores[:, perm]) + tuple(g[..., perm] for g in grid)


@dataclass
class _Setup:
    """One log made ready for Gauss-Newton: the problem, the windows' starts, the unknowns' start and scale."""
    prob: "_Problem"
    starts: np.ndarray  # (windows, 4) alpha, alpha', beta, beta' at each window's first sample
    theta: np.ndarray  # J/B, the motors' start states, the freed values, the further lags' start states (lags)
    scale: np.ndarray  # what "negligible" means per unknown (the stopping rule)
    win: int
    block: int
    n: int
    windows: int
    step_s: float
    y: np.ndarray
    given: list  # the freed values' starts
    lags: tuple = ()  # the further lags' start states estimated (LAG_START_NAMES), after the freed values in theta

    @property
    def kinked(self) -> bool:
        """Does the model hold an end stop (model.plant.STOP_SLOT: low < high)?  Its cost then has kinks."""
        b = self.prob.base
        return bool(b[STOP_SLOT] < b[STOP_SLOT + 1] or b[STOP_SLOT + 2] < b[STOP_SLOT + 3])

    @property
    def start_idx(self) -> np.ndarray:
        """theta's start states: the motors' (4..NG) and the further lags' (the last ones)."""
        return np.r_[4:NG, self.theta.size - len(self.lags):self.theta.size]


def setup(u1, u2, alpha, beta, dt, params, law, theta0, noise_rad, window_s=WINDOW_S, gravity_offset_rad=0.0,
          t_s=None, free=(), switch_delay_s=None, effects=None, torques=None, start_states0=None,
          substep_s=None) -> _Setup:
    """refine's arguments (see there) as a ready problem: shared by refine and the joint fit over several logs."""
    n = alpha.size
    t = np.arange(n) * dt if t_s is None else np.asarray(t_s, dtype=float)
    h = np.diff(t)
    step_s = float(np.median(h))
    block = max(int(round(BLOCK_S / step_s)), 1)
    win = max(int(round(window_s / step_s)) // block, 1) * block  # windows hold whole blocks
    nw = max(n // win, 1)
    y = np.ascontiguousarray(np.column_stack([alpha, beta]))
    sig = np.array([max(noise_rad.get("alpha", 0.0), 1e-12), max(noise_rad.get("beta", 0.0), 1e-12)])
    starts = np.array([[alpha[s], _start_velocity(alpha, t, s), beta[s], _start_velocity(beta, t, s)]
                       for s in range(0, nw * win, win)])
    free = tuple(free)
    # the bench's structure where the caller's dict of known values holds it (model.structure.with_structure:
    # diagnose's), beneath the caller's own slots
    effects = {**slot_values(of_bench(params)), **dict(effects or {})}
    exogenous = tuple(torques or {})
    given = [float(params[k] if k in _P else effects.get(k, 0.0)) for k in free]  # the freed values' starts
    clips = {INPUT_SLOTS[k]: float(effects.pop(k)) for k in list(effects) if k in INPUT_SLOTS}
    if any(k in INPUT_SLOTS and not g > 0 for k, g in zip(free, given)):
        raise ValueError("a freed input saturation or shifted dead zone needs a positive starting value [V] in "
                         "effects")
    motor0 = steady_motor_states(u1[0], u2[0], params, bool(effects.get("structure:reaction_voltage")))
    # a second-order motor's further lag starts where the first voltage's steady state has it unless told
    lag0 = [float(u1[0]), float(u2[0])]
    if start_states0:
        motor0 = np.array([start_states0.get(k, v) for k, v in zip(START_NAMES, motor0)], dtype=float)
        lag0 = [float(start_states0.get(k, v)) for k, v in zip(LAG_START_NAMES, lag0)]
        starts[0, 1] = start_states0.get("alpha_dot_0_rad_s", starts[0, 1])
        starts[0, 3] = start_states0.get("beta_dot_0_rad_s", starts[0, 3])
    base = model_vector(params, gravity_offset_rad, effects, exogenous)
    # the further lags' starts are unknowns where their motor is second order (T2 > 0)
    lags = tuple(k for k, s in zip(LAG_START_NAMES, (LAG1_SLOT, LAG2_SLOT)) if base[s] > 0.0)
    lag_given = [lag0[LAG_START_NAMES.index(k)] for k in lags]
    theta = np.concatenate([[theta0[k] for k in NAMES], motor0, given, lag_given])
    # what "negligible" means per unknown: J/B and freed values relative to themselves, start states to the
    # motors' (and the lags' to the voltages') range
    motor_range = np.abs(steady_motor_states(float(np.max(np.abs(u1))), float(np.max(np.abs(u2))), params))
    volts = {"lag1_0": float(np.max(np.abs(u1))), "lag2_0": float(np.max(np.abs(u2)))}
    scale = np.concatenate([np.abs(theta[:4]), np.maximum(motor_range, 1e-6) * 1e3,
                            np.maximum(np.abs(np.asarray(given, dtype=float)), 1e-9),
                            [max(volts[k], 1e-6) * 1e3 for k in lags]])
    prob = _Problem(readonly(u1), readonly(u2), y, 1.0 / sig,
                    base, law == "signed", h,
                    np.zeros((n, 2)) if switch_delay_s is None else np.ascontiguousarray(switch_delay_s, dtype=float),
                    win, block,
                    [INPUT_SLOTS.get(k) or slot(k, exogenous) for k in free] + [LAG_START_SLOTS[k] for k in lags],
                    torques=_held(torques, n) if exogenous else None,
                    clips={i: v for i, v in clips.items() if i not in [INPUT_SLOTS.get(k) for k in free]},
                    max_sub=(COULOMB_SUBSTEP_S if any(k in free or effects.get(k) for k in COULOMB_KEYS)
                             else substep_s or MAX_SUBSTEP_S),
                    lag0=tuple(lag0))
    return _Setup(prob, starts, theta, scale, win, block, n, nw, step_s, y, given, lags)


def refine(u1, u2, alpha, beta, dt: float, params: dict, law: str, theta0: dict, noise_rad: dict,
           window_s: float = WINDOW_S, gravity_offset_rad: float = 0.0, t_s: np.ndarray | None = None,
           free: tuple[str, ...] = (), switch_delay_s: np.ndarray | None = None,
           effects: dict | None = None, max_iterations: int = MAX_ITERATIONS,
           torques: dict | None = None, start_states0: dict | None = None, hold: bool = False,
           interval: bool = True, substep_s: float | None = None) -> Refined:
    """Gauss-Newton on the noise-weighted angle errors, from theta0 (DREM's estimate).

    ``t_s``: the sample stamps [s] when they are not uniform (default: uniform steps of ``dt`` [s]); the
    voltages are held over each actual interval.  ``switch_delay_s`` (n, 2): u1[k], u2[k] take effect this long
    after stamp k (the voltage topic's own times; default 0).  ``free``: known values (names of the parameter table) to
    estimate with J/B, started from ``params``; a saturation's or shifted dead zone's key (INPUT_SLOTS) among them
    is estimated too, its level or width started from ``effects`` (the logged voltages are shifted and clipped
    inside the fit; held, such an effect in ``effects`` transforms them at its value).  ``gravity_offset_rad``: a centre-of-mass offset, gravity
    Mg sin(alpha + delta) (diagnose's extended model; an encoder offset is handled by the caller, shifting
    the logged angle).  ``effects``: effect key (EFFECT_SLOTS) -> value in the model; an effect key in ``free``
    is estimated with J/B, started from its value there (or 0).  ``max_iterations``: Gauss-Newton's limit (a
    profile over a candidate's value, diagnosis/oe.py, needs the cost near each trial value, not convergence).
    ``torques``: effect key -> (n, 2) its torque per unit parameter on pitch and yaw [N m / unit], computed by
    the caller from the measured states (an effect not compiled into the kernel: model/effects.py); the
    torque is held over each sample interval at the mean of its two ends, its parameter taken from
    ``effects`` (or 0) and estimated when its key is in ``free``.  ``start_states0``: where the motor and lag
    start states (START_NAMES, and LAG_START_NAMES for a second-order motor's further lag) and the first window's
    rates (alpha_dot_0_rad_s, beta_dot_0_rad_s) begin, e.g. a previous fit's ``start_states`` (default: the motors'
    steady state for the first voltages, rates from the angles' first 50 ms).  A second-order motor's further lag
    start (the motor's effect ``motor_second_lag:...`` in ``effects`` with T2 > 0) is estimated with the others and
    reported among ``start_states``.  ``hold``: J/B and the freed values stay at theta0 and their starts, only the start
    states (the motors' and each window's) are fitted: a model fitted elsewhere simulated on these samples (a
    held-out check); the intervals are then those of the values held, not estimates.  ``interval`` False: the
    caller needs the values, cost and predictions alone (a profile's or a screen's trial fit, ``max_iterations``
    steps): the last step's trial pass integrates no sensitivity and no interval is computed (ci95, standard
    errors, pending_decrease NaN; fit and cov_jb None).  The same values, cost and predictions: the states are
    integrated alike with or without their sensitivities.  ``substep_s``: the RK4 sub-step's bound [s] instead of
    MAX_SUBSTEP_S (a trial fit's TRIAL_SUBSTEP_S; not with a Coulomb friction: COULOMB_SUBSTEP_S)."""
    su = setup(u1, u2, alpha, beta, dt, params, law, theta0, noise_rad, window_s, gravity_offset_rad, t_s, free,
               switch_delay_s, effects, torques, start_states0, substep_s)
    prob, starts, theta, scale, win, block, n = su.prob, su.starts, su.theta, su.scale, su.win, su.block, su.n
    step_s = su.step_s
    ng = theta.size
    held = su.start_idx
    out = np.empty((n, 2))
    cost, a, b, scores = prob.evaluate(theta, starts, out)
    converged, it = False, 0
    for it in range(1, max_iterations + 1):
        s_mat, s_rhs, per_window = schur(a, b, ng)
        step = scaled_inverse(s_mat) @ s_rhs
        if hold:  # only the start states move among the globals
            step = start_step(s_mat, s_rhs, held)
        step_starts = np.array([k[:, ng] - k[:, :ng] @ step for k in per_window])
        se = np.sqrt(np.maximum(np.diag(batch_covariance(s_mat, per_window, scores, win, block)), 0.0))
        small = (np.abs(step) <= STEP_OVER_SE * se) | (np.abs(step) <= TOLERANCE * scale)
        # the decrease in cost the full step predicts: the global unknowns' through the Schur complement plus what
        # the windows' starts still gain with the globals held (x'b = x_G's_rhs + sum_w b_L' A_LL^-1 b_L); the first
        # term alone stopped fits whose window starts had ~20 to gain (a profile over an offset jumped by 24)
        pending = float(step @ s_rhs) + sum(float(b[w, ng:] @ k[:, ng]) for w, k in enumerate(per_window))
        settled = pending < MIN_COST_DECREASE and bool(np.all(
            small[:4] | (np.abs(step[:4]) <= JB_STEP_OVER_SE * se[:4])))
        if it > 1 and (np.all(small) or settled):
            converged = True  # the next step would not move anything that matters: stop here, where the
            break  # normal equations (and so the interval) were evaluated
        lam, accepted = 1.0, None
        trial = np.empty((n, 2))
        last = not interval and it == max_iterations  # no step follows: its normal equations are never used
        slope = -2.0 * (float(step @ b[:, :ng].sum(axis=0)) + float(np.sum(step_starts * b[:, ng:])))
        while lam >= 1e-4:  # backtracking keeps every iteration downhill
            th_new, st_new = theta + lam * step, starts + lam * step_starts
            trial_cost = math.nan
            # a trial far out (a step of an ill-conditioned fit) may overflow: it is a failed trial, not a warning
            if np.all(th_new[:4] > 0) and np.all(np.isfinite(th_new)) and np.all(np.isfinite(st_new)):
                with np.errstate(all="ignore"):
                    res = prob.evaluate(th_new, st_new, trial, cost_only=True, predict_only=last)
                if res[0] <= cost:
                    accepted = th_new, st_new, res
                    break
                trial_cost = res[0] if math.isfinite(res[0]) else math.nan
            lam = backtrack(lam, cost, slope, trial_cost)
        if accepted is None:  # no downhill step: at the minimum to working precision
            # with end stops in the model the cost has kinks where an angle meets its stop (its sensitivities know
            # nothing of when it does), so the Gauss-Newton step need not be small at the minimum: no step along it
            # lowering the cost is then the minimum (measured: logs of the CE150's published model stopped here at
            # their noise floor with every J/B within 0.02 % of the truth, and were called not converged)
            converged = su.kinked or bool(np.all(np.abs(step[:4]) <= np.maximum(1e-6 * theta[:4], 0.1 * se[:4])))
            break
        theta, starts, res = accepted
        if last:  # the loop ends here: refine's result without an interval, below
            cost, out = res[0], trial
            break
        if prob.differenced:  # the differenced columns need their own passes, from the trial's predictions
            cost, a, b, scores = prob.evaluate(theta, starts, out, known=trial)
        else:  # the trial pass was the full pass at the accepted point: keep it
            (cost, a, b, scores), out = res, trial
    if not interval:  # no normal equations read: every interval and standard error NaN
        return _refined(su, theta, starts, cost, out, it, free, converged, np.full(theta.size, math.nan), 1.0,
                        np.full(4, math.nan), np.zeros(4), None, math.nan, None)
    s_mat, s_rhs, per_window = schur(a, b, ng)
    cov = batch_covariance(s_mat, per_window, scores, win, block)
    pending = float(scaled_inverse(s_mat) @ s_rhs @ s_rhs) + sum(float(b[w, ng:] @ k[:, ng])
                                                                 for w, k in enumerate(per_window))
    nb = scores.shape[0]
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    tq = float(stdtrit(max(nb - 1, 1), 0.975))
    half = tq * se[:4]
    integration = np.zeros(4)
    sub_s = step_s / substeps(step_s, prob.max_sub)  # the RK4 sub-step of a median sample interval [s]
    if np.any(half < RICHARDSON_BELOW * (sub_s / MAX_SUBSTEP_S) ** 4 * theta[:4]):
        # intervals this narrow (noise-free logs) meet the integrator's own error: estimate it from the
        # parameter shift that halving the sub-step causes (RK4: the error falls 16-fold) and add twice that
        fine = prob.evaluate(theta, starts, np.empty((n, 2)), sub_s / 2.0)
        _, rhs_fine, _ = schur(fine[1], fine[2], ng)
        integration = np.abs(scaled_inverse(s_mat) @ (rhs_fine - s_rhs))[:4] * 16.0 / 15.0
        half = half + 2.0 * integration
    half = np.maximum(half, 10.0 * TOLERANCE * theta[:4])  # no claim finer than the convergence test
    return _refined(su, theta, starts, cost, out, it, free, converged, se, tq, half, integration,
                    _Fit(prob, theta, starts, a, b), pending, cov[:4, :4].copy())


def _refined(su, theta, starts, cost: float, out: np.ndarray, it: int, free: tuple, converged: bool,
             se: np.ndarray, tq: float, half: np.ndarray, integration: np.ndarray, fit, pending: float, cov_jb
             ) -> Refined:
    """refine's result at ``theta``, ``starts`` (cost, predictions ``out``): ``se`` every unknown's standard
    error, ``tq`` the Student quantile of the freed values' intervals, ``half`` J/B's half-widths."""
    names = START_NAMES + su.lags
    held = su.start_idx
    start_states = {**dict(zip(names, map(float, theta[held]))),
                    "alpha_dot_0_rad_s": float(starts[0, 1]), "beta_dot_0_rad_s": float(starts[0, 3])}
    freed = {k: {"estimate": float(theta[NG + j]), "ci95": [float(theta[NG + j] - tq * se[NG + j]),
                                                            float(theta[NG + j] + tq * se[NG + j])],
                 "se": float(se[NG + j]), "table_or_file_value": su.given[j]}
             for j, k in enumerate(free)}
    return Refined(dict(zip(NAMES, map(float, theta[:4]))),
                   {k: (float(theta[i] - half[i]), float(theta[i] + half[i])) for i, k in enumerate(NAMES)},
                   converged, it, angle_rms(su.y, out), float(cost), su.win * su.step_s,
                   su.windows, substeps(su.step_s, su.prob.max_sub), max(su.n // su.block, 1),
                   {k: float(integration[i]) for i, k in enumerate(NAMES)}, start_states,
                   dict(zip(names, map(float, se[held]))), out, freed, fit, pending, cov_jb)


def trial_substep(noise_rad: dict) -> float | None:
    """A trial fit's ``substep_s`` on a log whose angles' noise floors are ``noise_rad`` [rad]: TRIAL_SUBSTEP_S
    where both are at least TRIAL_MIN_FLOOR_RAD, else None (MAX_SUBSTEP_S)."""
    return TRIAL_SUBSTEP_S if min(noise_rad.values()) >= TRIAL_MIN_FLOOR_RAD else None


def trial_options(noise_rad: dict) -> dict:
    """refine's options for a trial fit (a profile's or a screen's, whose values, cost and predictions alone are
    used) on a log whose angles' noise floors are ``noise_rad`` [rad]: no interval, trial_substep's sub-step."""
    return {"interval": False, "substep_s": trial_substep(noise_rad)}


def start_step(s_mat: np.ndarray, s_rhs: np.ndarray, held: np.ndarray) -> np.ndarray:
    """A Gauss-Newton step of the global unknowns at ``held`` alone (the start states: _Setup.start_idx), the others
    kept: their block of the Schur complement."""
    step = np.zeros(s_rhs.size)
    step[held] = scaled_inverse(s_mat[np.ix_(held, held)]) @ s_rhs[held]
    return step


def backtrack(lam: float, cost: float, slope: float, trial_cost: float) -> float:
    """The next step length after the one at ``lam`` failed to lower the cost (Nocedal & Wright, Numerical
    Optimization, sec. 3.5): the minimum of the parabola through the cost at 0, its slope there along the step
    (``slope`` < 0) and the failed trial's cost, kept within 0.1-0.5 of ``lam``; 0.1 lam when the trial had no
    finite cost (J or B not positive there, or the simulation overflowed), half when the slope is no descent.
    Far from the model's basin (a log the model does not fit, a profile's trial value far off) the cost curves
    so sharply that steps of 1e-4 still climb: halving spent 14 passes on each such search, this 4 to 5."""
    if not math.isfinite(trial_cost):
        return 0.1 * lam
    if not slope < 0.0:
        return 0.5 * lam
    curvature = trial_cost - cost - slope * lam
    if not curvature > 0.0:
        return 0.5 * lam
    return min(max(-slope * lam * lam / (2.0 * curvature), 0.1 * lam), 0.5 * lam)


def _held(torques: dict, n: int) -> np.ndarray:
    """(n, 2, m) the torques held over each sample interval: the mean of the interval's two ends (the last
    sample's own value after it, never used)."""
    out = np.empty((n, 2, len(torques)))
    for j, t in enumerate(torques.values()):
        t = np.asarray(t, dtype=float)
        if t.shape != (n, 2):
            raise ValueError(f"an exogenous torque must be (n, 2) = ({n}, 2), not {t.shape}")
        out[:-1, :, j] = 0.5 * (t[:-1] + t[1:])
        out[-1, :, j] = t[-1]
    return out


@dataclass(frozen=True)
class _Fit:
    """What a score test on further unknowns needs: the problem and the fit's normal equations."""
    problem: _Problem
    theta: np.ndarray
    starts: np.ndarray
    a: np.ndarray
    b: np.ndarray


#: known values that --free can move into the estimated set (every model value but J/B)
FREEABLE = _P[4:]
#: known values the suspect test tries (the motors' and thrusts' gains, gravity, gyroscope, reaction)
SUSPECTS = ("Mg", "Kg", "a1", "b1", "a2", "b2", "k1", "k2", "T11", "T21", "kc", "T0", "Tp")


def suspect_known_values(r: Refined, candidates: tuple[str, ...] = SUSPECTS) -> dict:
    """Score test for each known value: how much of the fit's excess cost (above the noise floor's) one
    Gauss-Newton step with that value set free would remove, J/B, start states and window starts re-fitted.
    Returns name -> fraction of the excess (0..1), largest first.  Linear in the freed value: a guide to
    which known value the data blame, not an estimate of it."""
    return known_value_scores(r, candidates)[0]


def known_value_scores(r: Refined, candidates: tuple[str, ...] = SUSPECTS, values: dict | None = None
                       ) -> tuple[dict, dict]:
    """(suspect_known_values' scores, the precision the log's sensitivities allow each value): one pass of the
    fit's model with the candidates' sensitivities.  The precision is the 95 % half-width over |value| (``values``:
    the values the fit used) from the Fisher information at the fit, the angles weighted by the floors it was
    given: "alone" each value freed by itself with J/B, the start states and the window starts, "together" all the
    candidates freed at once (inf where the others can stand in for it).  White errors at the floors are assumed:
    it is the most the log could tell, not an interval."""
    fit = r.fit
    prob = fit.problem
    n = prob.y.shape[0]
    ng = fit.a.shape[1] - NL
    cand = [k for k in candidates if _P.index(k) not in prob.free_idx]
    # order: globals (J/B, start states), freed, candidates, window starts
    cost, a, b, _ = prob.evaluate(fit.theta, fit.starts, np.empty((n, 2)), more=[_P.index(k) for k in cand])
    s_mat, s_rhs, _ = schur(a, b, ng + len(cand))
    base = s_rhs[:ng] @ scaled_inverse(s_mat[:ng, :ng]) @ s_rhs[:ng]
    excess = max(cost - 2.0 * n, 1e-300)
    out = {}
    for j, k in enumerate(cand):
        idx = np.r_[0:ng, ng + j]
        gain = s_rhs[idx] @ scaled_inverse(s_mat[np.ix_(idx, idx)]) @ s_rhs[idx] - base
        out[k] = float(min(max(gain / excess, 0.0), 1.0))
    scores = dict(sorted(out.items(), key=lambda kv: -kv[1]))
    values = values or {}
    scale = np.array([abs(values.get(k, math.nan)) for k in cand])
    alone = relative_half_widths(s_mat, ng, scale, together=False)
    together = relative_half_widths(s_mat, ng, scale, together=True)
    return scores, {"alone": dict(zip(cand, map(float, alone))), "together": dict(zip(cand, map(float, together)))}


#: the share of a value's information the others may explain before it counts as not determined at all
#: (relative_half_widths: the Schur complement's round-off floor)
UNDETERMINED_SHARE = 1e-9


def relative_half_widths(s_mat: np.ndarray, ng: int, scale: np.ndarray, together: bool) -> np.ndarray:
    """The Fisher-information 95 % half-width of each parameter after the first ``ng`` of the information matrix
    ``s_mat``, over ``scale`` (its magnitude): 1.96 / sqrt(the Schur complement of its diagonal entry given the
    first ``ng`` and, ``together``, every other parameter).  inf where the others explain all but
    UNDETERMINED_SHARE of its information (they can stand in for it) or scale is not positive."""
    m = s_mat.shape[0] - ng
    out = np.full(m, math.inf)
    for j in range(m):
        others = np.r_[0:ng, ng:ng + m] if together else np.r_[0:ng]
        others = others[others != ng + j]
        s_jj = s_mat[ng + j, ng + j]
        s_jo = s_mat[ng + j, others]
        comp = s_jj - s_jo @ (scaled_inverse(s_mat[np.ix_(others, others)]) @ s_jo)
        if s_jj > 0 and comp > UNDETERMINED_SHARE * s_jj and scale[j] > 0:
            out[j] = 1.96 / math.sqrt(comp) / scale[j]
    return out


def angle_rms(y, pred) -> dict:
    e = y - pred
    return {"alpha": float(np.sqrt(np.mean(e[:, 0] ** 2))), "beta": float(np.sqrt(np.mean(e[:, 1] ** 2)))}
