"""Shared fixtures: simulated logs with known truth (ODE-generated, cached per session)."""
from __future__ import annotations

import functools

import pytest

from sim import SimSettings, simulate
from trms_ident.io.csv_log import truth_path, write_csv_log
from trms_ident.log import validated


@functools.lru_cache(maxsize=None)
def sim_cached(ref: str, rate: float = 1000.0, duration: float | None = None, noise: float = 0.0,
               quantization: float = 0.0, seed: int = 0, effects: tuple = ()):
    return simulate(SimSettings(ref=ref, sample_rate_hz=rate, duration_s=duration, noise_std_rad=noise,
                                quantization_rad=quantization, seed=seed,
                                effects=[dict(e) for e in effects]))


def as_log(r):
    return validated(r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, source="<sim>")


@pytest.fixture(scope="session")
def square_csv(tmp_path_factory):
    """Paper square experiment, 1 kHz, 20 s (short, for CLI tests), with its truth file."""
    import json

    path = tmp_path_factory.mktemp("logs") / "square.csv"
    r = sim_cached("square", 1000.0, 20.0)
    write_csv_log(path, r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad)
    truth_path(path).write_text(json.dumps(r.truth))
    return path
