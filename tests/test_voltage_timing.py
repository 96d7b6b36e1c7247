"""Voltages that act at their own time stamps (MCAP topics offset from the angles; CSV column t_u)."""
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from sim import SimSettings, simulate
from trms_ident.cli import app
from trms_ident.identify import identify
from trms_ident.io.csv_log import write_csv_log
from trms_ident.io.mcap_log import write_mcap_log
from trms_ident.io.readers import read_log

runner = CliRunner()
Q12 = 2 * np.pi / 4096


@pytest.mark.parametrize("jitter", [0.0, 0.2])
@pytest.mark.parametrize("offset", [0.0, 0.2, 0.5, 0.9])
def test_same_run_as_csv_and_mcap_gives_the_truth(tmp_path, offset, jitter):
    r = simulate(SimSettings(ref="multisine", sample_rate_hz=500.0, duration_s=60.0, quantization_rad=Q12, seed=4,
                             voltage_offset=offset, jitter=jitter))
    write_mcap_log(tmp_path / "run.mcap", r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, u_t_s=r.u_time_s)
    write_csv_log(tmp_path / "run.csv", r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad,
                  u_t_s=r.u_time_s if offset else None)
    got = {}
    for fmt in ("csv", "mcap"):
        log = read_log(tmp_path / f"run.{fmt}")
        assert (log.u_switch_s is None) == (offset == 0.0)
        res = identify(log)
        assert res.model_check["adequate"], (fmt, res.model_check["sentence"])
        assert res.headline == "refined", res.refine_note
        for k, v in r.truth["estimated"].items():
            assert res.estimates[k] == pytest.approx(v, rel=0.01 if k.startswith("J") else 0.03), (fmt, k)
        got[fmt] = res.estimates
    for k in got["csv"]:
        assert got["mcap"][k] == pytest.approx(got["csv"][k], rel=5e-4), k


def test_offset_is_measured_and_reported_and_the_old_convention_is_available(tmp_path):
    r = simulate(SimSettings(ref="sine", sample_rate_hz=1000.0, duration_s=40.0, quantization_rad=Q12, seed=1,
                             voltage_offset=0.2))
    path = tmp_path / "run.mcap"
    write_mcap_log(path, r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, u_t_s=r.u_time_s)
    res = runner.invoke(app, ["estimate", str(path), "-o", str(tmp_path / "o"), "--no-report", "--json", "-"])
    assert res.exit_code == 0, res.output
    vt = json.loads(res.stdout)["input"]["voltage_timing"]
    off = vt["offset_after_angle"]["/trms/voltage"]
    assert off["median_ms"] == pytest.approx(0.2, abs=1e-3) and off["median_samples"] == pytest.approx(0.2, abs=1e-3)
    assert vt["convention"] == "stamp" and vt["clocks"]["/trms/joint_states"] == "header.stamp"
    assert "0.2 ms (0.20 samples) after the angle stamp" in res.stderr
    # the first angle sample precedes every voltage and is dropped, so log sample j is angle sample j + 1:
    # stamped, it holds the message sent just after it (j + 1); the old convention holds the one before (j)
    new = read_log(path)
    old = read_log(path, voltage_time="next-sample")
    assert old.u_switch_s is None and new.u_switch_s is not None
    np.testing.assert_array_equal(new.u1_v, r.u1_v[1:])
    np.testing.assert_array_equal(old.u1_v, r.u1_v[:-1])
    bad = runner.invoke(app, ["estimate", str(path), "--voltage-time", "late", "-o", str(tmp_path / "p")])
    assert bad.exit_code == 2 and "--voltage-time 'late': expected one of stamp, next-sample" in bad.output


def test_a_voltage_outside_its_interval_is_refused(tmp_path):
    r = simulate(SimSettings(ref="square", sample_rate_hz=100.0, duration_s=5.0, seed=1))
    t_u = r.t_s.copy()
    t_u[30] = r.t_s[31] + 0.001  # after the next sample's stamp
    path = tmp_path / "bad.csv"
    write_csv_log(path, r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, u_t_s=t_u)
    res = runner.invoke(app, ["estimate", str(path), "-o", str(tmp_path / "o")])
    assert res.exit_code == 4
    assert "line 32 (t = 0.3 s): a voltage takes effect at" in res.output and "outside its sample interval" in res.output
