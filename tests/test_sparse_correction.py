"""Physics outside the library: diagnose locates it, describes it with a sparse data-driven correction (pysindy
STLSQ on the residual torque), shows the fit improve, and never calls it explained."""
import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from sim import SimSettings, simulate
from trms_ident.cli import app
from trms_ident.diagnosis import sparse
from trms_ident.diagnosis.run import diagnose
from trms_ident.io.csv_log import write_csv_log

from .conftest import as_log

Q12 = 2 * math.pi / 4096
runner = CliRunner()


def _log(ref, overrides, seed=21, duration_s=120.0):
    # known values off Table 1 in the plant, table values in diagnose: physics no named effect describes
    return simulate(SimSettings(ref=ref, duration_s=duration_s, sample_rate_hz=200.0, quantization_rad=Q12, seed=seed,
                                overrides=overrides))


#: two known values off, one per axis: no known value alone explains the log and no effect of the library
#: describes either axis' mismatch.  Refitted together the two values do (known_values.joint, which
#: tests/test_known_values.py checks on this same bench); these tests take that joint search out
#: (no_joint) to test the correction, diagnose's last resort, on a mismatch whose form is known
TWO_OFF = {"Kg": 0.1, "kc": -0.1}


@pytest.fixture
def no_joint(monkeypatch):
    from trms_ident.diagnosis import weigh

    monkeypatch.setattr(weigh, "_joint", lambda *args: None)


def test_outside_the_library_is_described_and_raises_the_fit(no_joint):
    # a known defect until lately (issue #47, measured 1 Dec 2026 at 760f54f: with the joint known-value search taken
    # out, a yaw thrust asymmetry, a 0.937 V pitch dead zone and a yaw dead zone were named); measured 5 Dec 2026 at
    # a28a279 and at this session's end: no finding, each candidate refused with its reason, unexplained, both
    # corrections found (the strict xfail had turned XPASS in the slow set, which CI does not run)
    # the gyroscopic coupling twice the table's Kg: the correction adds -Kg M1 beta' cos(alpha) once more (the
    # reaction moment's case, through the command line: test_cli_reports_the_correction_in_words_and_json)
    axis, term, coefficient = "pitch", "gyroscopic", -0.05
    r = _log("multisine", TWO_OFF)
    d = diagnose(as_log(r))
    assert d.verdict in ("partly_explained", "unexplained")  # never explained by a correction
    assert not d.findings  # no named effect (tests/test_model_room.py adds one for it: then it is explained)
    assert d.seed_check["known_values"]["named"] is None  # each value alone leaves the other axis off
    assert d.known_values_joint is None  # taken out (no_joint)
    (c,) = [c for c in d.corrections if c.axis == axis]
    names = [t["term"] for t in c.terms]
    assert names == [term], c.terms
    assert c.terms[0]["coefficient"] == pytest.approx(coefficient, rel=0.3)
    assert not math.isfinite(c.fit_before) or c.fit_after > c.fit_before
    assert c.fit_after > 99.0
    truth = r.truth["estimated"]
    jb = ("J1", "B1") if axis == "pitch" else ("J2", "B2")
    for k in jb:  # the axis refitted with the correction recovers the plant's J and B
        assert c.estimates[k] == pytest.approx(truth[k], rel=0.02)
    assert "outside the library" in d.verdict_sentence.lower()
    # the correction as the bench file carries it (a [terms] entry), fitted by output error with J/B and the start
    # states: its c with an interval, and the held-out simulation of its axis raised (held_out.correction_fits)
    assert c.terms[0]["key"] == "term(M1*beta'*cos(alpha)):pitch"
    fit = c.output_error
    v = fit["values"]["term(M1*beta'*cos(alpha)):pitch"]
    assert v["estimate"] == pytest.approx(coefficient, rel=0.1) and v["ci95"][0] < v["estimate"] < v["ci95"][1]
    assert fit["held_out"]["after"] > fit["held_out"]["before"] + 1.0, fit["held_out"]
    assert fit["estimates"]["J1"] == pytest.approx(truth["J1"], rel=0.02)


def test_clean_log_gets_no_correction():
    r = simulate(SimSettings(ref="multisine", duration_s=90.0, sample_rate_hz=200.0, quantization_rad=Q12, seed=5))
    d = diagnose(as_log(r))
    assert d.verdict == "consistent" and not d.corrections


def test_library_cannot_rebuild_the_right_hand_side():
    """Without the forward thrust the terms cannot cancel eq. (1)'s right-hand side (0 = 0 with J = B = 0)."""
    names = {(t.axis, t.name) for t in sparse.LIBRARY}
    assert ("pitch", "thrust_forward") not in names and ("yaw", "thrust_forward") not in names
    assert not sparse._keeps_physics(np.array([1e-9, 1e-9]), np.array([0.068, 0.006]))
    assert sparse._keeps_physics(np.array([0.02, 0.1]), np.array([-0.17, 0.15]))  # repairs a non-physical fit


@pytest.mark.parametrize("ratio, kept", [(1.49, True), (0.51, True), (1.51, False), (0.49, False)])
def test_a_correction_may_move_j_or_b_by_at_most_half(ratio, kept):
    """A correction describes a torque the model misses; one whose joint fit moves J or B by more than half their
    values with the named effects (sparse.MAX_JB_CHANGE) replaces the model's inertia or damping instead."""
    before = np.array([0.068, 0.006])
    assert sparse._keeps_physics(before * np.array([1.0, ratio]), before) is kept
    assert sparse._keeps_physics(before * np.array([ratio, 1.0]), before) is kept


def test_cli_reports_the_correction_in_words_and_json(tmp_path, no_joint):
    # the reaction moment half the table's: the correction gives back +0.5 M_R (40 s: diagnose takes 20 s on it, 130 s
    # on 120 s, where the profile scans of the input modifications run over a longer misfit)
    r = _log("steps", TWO_OFF, duration_s=40.0)
    path = tmp_path / "kc.csv"
    write_csv_log(path, r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad)
    res = runner.invoke(app, ["diagnose", str(path), "-o", str(tmp_path / "out"), "--json", "-"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["verdict"] == "unexplained"
    (c,) = [c for c in doc["corrections"] if c["axis"] == "yaw"]
    assert c["axis"] == "yaw" and "reaction torque on yaw is about 50% weaker" in c["sentence"]
    assert [t["term"] for t in c["terms"]] == ["reaction"], c["terms"]
    assert c["terms"][0]["coefficient"] == pytest.approx(0.5, rel=0.3)
    fb = c["fit_before"]
    assert c["fit_after"] > 99.0 and (fb is None or not math.isfinite(fb) or c["fit_after"] > fb)
    for k in ("J2", "B2"):  # the axis refitted with the correction recovers the plant's J and B
        assert c["estimates"][k] == pytest.approx(r.truth["estimated"][k], rel=0.02)
    assert "outside the library, yaw" in res.stderr
    assert c["terms"][0]["key"] == "term(MR):yaw"  # carried as a [terms] entry, fitted by output error
    assert c["output_error"]["values"]["term(MR):yaw"]["estimate"] == pytest.approx(0.5, rel=0.3)
    assert c["output_error"]["held_out"]["after"] > c["output_error"]["held_out"]["before"]
    assert "fitted by output error with the findings (J/B and the start states free): held-out yaw fit" in res.stderr
    html = (tmp_path / "out" / "report.html").read_text()
    assert "outside the library" in html and "Correction of the yaw torque" in html


def test_a_small_relative_change_is_said_with_its_digits():
    from trms_ident.diagnosis.sparse import _pct

    assert (_pct(0.4), _pct(-0.4), _pct(0.0038)) == ("40%", "40%", "0.38%")  # was "0%"
