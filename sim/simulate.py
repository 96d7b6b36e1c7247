"""Python face of the simulator: settings in, a synthetic log and its ground truth out."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from trms_ident.params import THRUST_LAWS, merge

from . import effects as fx
from .plant import PARAM_ORDER, closed_loop
from .references import REFERENCES, TABLE, reference, tabulated

#: PID (eq. 9) gains per axis [V/rad, V/(rad s), V s/rad] and derivative filter [s].
#: The paper prints no usable values; these place the linearised closed-loop poles at
#: Re <= -0.2 rad/s (pitch) and -1.2 rad/s (yaw) for the seed parameters.
DEFAULT_PID = {"Kp1": 1.0, "Ki1": 2.0, "Kd1": 4.0, "Kp2": 3.5, "Ki2": 1.25, "Kd2": 2.2, "Tf": 0.02}
ENCODER_12BIT_RAD = 2 * math.pi / 4096

#: Paper experiments: duration [s] per reference when none is given.
DEFAULT_DURATION_S = {"square": 60.0, "sine": 120.0, "multisine": 120.0, "steps": 120.0, "chirp": 120.0}


@dataclass
class SimSettings:
    ref: str = "square"
    duration_s: float | None = None
    sample_rate_hz: float = 1000.0
    seed: int = 0
    noise_std_rad: float = 0.0
    quantization_rad: float = 0.0
    #: where the encoders' grids sit off zero [rad] (pitch, yaw): the angle logged is round((angle + o) / q) q - o,
    #: the controller reads round((angle + o) / q) q.  Rounding is otherwise the same on every seed: a benchmark
    #: that wants independent 12-bit runs draws these per seed
    quantization_offset_rad: tuple = (0.0, 0.0)
    thrust_law: str = "quadratic"
    u_limit_v: float = 2.5
    max_step_s: float = 5e-4
    jitter: float = 0.0  # sample intervals drawn uniformly in nominal x [1 - jitter, 1 + jitter] (seeded)
    start_s: float = 0.0  # the log begins this long after the run started from rest (0: from rest)
    voltage_offset: float = 0.0  # voltages reach the motors (and are stamped) this fraction of a step after the angles
    initial_yaw_rad: float = 0.0  # where the beam rests in yaw when the run starts (the encoder reads it as is)
    overrides: dict = field(default_factory=dict)
    effects: list = field(default_factory=list)
    pid: dict = field(default_factory=lambda: dict(DEFAULT_PID))
    #: with ref "file": (times [s] from 0, alpha_ref [rad], beta_ref [rad]), e.g. a design's references
    ref_table: tuple | None = None

    def validate(self) -> None:
        if self.ref == TABLE:
            if self.ref_table is None:
                raise ValueError(f"reference {TABLE!r} needs ref_table (times, alpha_ref, beta_ref)")
        elif self.ref_table is not None:
            raise ValueError(f"ref_table is given, so the reference must be {TABLE!r}, not {self.ref!r}")
        elif self.ref not in REFERENCES:
            raise ValueError(f"unknown reference {self.ref!r}; expected one of {', '.join(REFERENCES)}")
        if self.thrust_law not in THRUST_LAWS:
            raise ValueError(f"unknown thrust law {self.thrust_law!r}; expected one of {', '.join(THRUST_LAWS)}")
        for name in ("sample_rate_hz", "u_limit_v", "max_step_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if self.duration_s is not None and not self.duration_s > 0:
            raise ValueError(f"duration_s must be > 0, got {self.duration_s}")
        if not 0.0 <= self.voltage_offset < 1.0:
            raise ValueError(f"voltage_offset must be in [0, 1) of the sample step, got {self.voltage_offset}")
        if self.voltage_offset and any(e.get("effect") == "input_delay" for e in self.effects):
            raise ValueError("voltage_offset and an input_delay effect cannot be combined")
        if not 0.0 <= self.jitter <= 0.5:
            raise ValueError(f"jitter must be in [0, 0.5] of the sample step, got {self.jitter}")
        for name in ("noise_std_rad", "quantization_rad", "start_s"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")


@dataclass
class SimResult:
    t_s: np.ndarray
    u1_v: np.ndarray
    u2_v: np.ndarray
    alpha_rad: np.ndarray
    beta_rad: np.ndarray
    true_state: np.ndarray  # columns alpha, alpha', beta, beta' (noise-free)
    truth: dict  # true parameters and every setting: enough to reproduce the log
    u_time_s: np.ndarray  # when each voltage reached the motors [s] (t_s unless voltage_offset)


def simulate(settings: SimSettings) -> SimResult:
    settings.validate()
    table = settings.ref_table
    duration = settings.duration_s or (float(table[0][-1]) - settings.start_s if table is not None
                                       else DEFAULT_DURATION_S[settings.ref])
    if not duration > 0:
        raise ValueError(f"the reference table ends at {float(table[0][-1]):.6g} s, before the log's start "
                         f"{settings.start_s:.6g} s")
    fs = settings.sample_rate_hz
    skip = int(round(settings.start_s * fs))
    n = int(round(duration * fs)) + 1 + skip
    rng_t = np.random.default_rng([settings.seed, 1])
    dts = (1.0 + settings.jitter * rng_t.uniform(-1.0, 1.0, n)) / fs if settings.jitter else np.full(n, 1.0 / fs)
    t = np.concatenate([[0.0], np.cumsum(dts[:-1])]) if settings.jitter else np.arange(n) / fs
    params = merge(settings.overrides, source="simulator overrides")
    for spec in settings.effects:  # motor_lag replaces the true time constant
        if spec["effect"] == "motor_lag":
            params["T11" if spec.get("axis", "pitch") == "pitch" else "T21"] = float(spec["value"])
    effect_vec = np.array(fx.pack(settings.effects), dtype=float)
    if table is not None:  # jittered stamps may run past the table's end by at most jitter x the run's length
        aref, bref = tabulated(table, t, settings.jitter * (duration + settings.start_s))
    else:
        aref, bref = reference(settings.ref, t, settings.seed)
    rng = np.random.default_rng(settings.seed)
    noise = rng.standard_normal((2, n)) * settings.noise_std_rad
    grid = np.asarray(settings.quantization_offset_rad, dtype=float) if settings.quantization_rad > 0 else np.zeros(2)
    noise += grid[:, None]
    pid = {**DEFAULT_PID, **settings.pid}
    gains = np.array([pid[k] for k in ("Kp1", "Ki1", "Kd1", "Kp2", "Ki2", "Kd2", "Tf")], dtype=float)
    p = np.array([params[k] for k in PARAM_ORDER], dtype=float)
    x0 = np.zeros(9)  # at rest: motors, reaction lag and second-order drives at 0
    x0[0] = -effect_vec[fx.I_COM]  # at rest in the gravity equilibrium
    x0[2] = settings.initial_yaw_rad
    u1, u2, a_log, b_log, state = closed_loop(
        dts, aref, bref, p, 1 if settings.thrust_law == "signed" else 0, gains,
        settings.u_limit_v, effect_vec, noise[0], noise[1], settings.quantization_rad,
        settings.max_step_s, x0, settings.voltage_offset,
    )
    truth = {
        "generator": "trms-ident simulator (sim/)",
        "parameters": params,
        "estimated": {k: params[k] for k in ("J1", "B1", "J2", "B2")},
        "settings": {**asdict(settings), "duration_s": duration, "pid": pid,
                     "ref_table": None if table is None else {"rows": int(np.size(table[0])),
                                                              "end_s": float(table[0][-1])}},
        "samples": n - skip,
    }
    cut = slice(skip, None)  # a log cut from the middle of a run keeps the run's own clock
    u_time = t + settings.voltage_offset * dts
    a_log, b_log = a_log - grid[0], b_log - grid[1]
    return SimResult(t[cut], u1[cut], u2[cut], a_log[cut], b_log[cut], state[cut], truth, u_time[cut])
