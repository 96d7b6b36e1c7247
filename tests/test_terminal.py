"""diagnose's terminal words (report/terminal.py, issue #47 item 6): the verdict and the findings in plain words
first, the same words in batch's summary; pure, on diagnosis.json-shaped findings."""
from trms_ident.report.terminal import HEADLINES, LEADS, finding_words, headline, listed


def _effect(effect, axis, name, value, unit):
    return {"effect": effect, "axis": axis, "parameter": {"name": name, "value": value, "unit": unit}}


def test_each_kind_of_finding_reads_as_words_with_its_value_and_unit():
    assert finding_words(_effect("cable_stiffness", "yaw", "k", 0.004, "N m/rad")) == "a cable on yaw (k = 0.004 N m/rad)"
    assert finding_words(_effect("motor_second_lag", "yaw", "T2", 0.463, "s")) == \
        "a second-order tail motor (T2 = 0.463 s)"
    assert finding_words(_effect("shifted_dead_zone", "pitch", "w", 0.25, "V")) == \
        "a dead zone on the main motor (w = 0.25 V)"
    assert finding_words(_effect("dead_zone", "yaw", "w", 0.25, "V")) == \
        "a cut-off dead zone on the tail motor (w = 0.25 V)"
    kv = {"effect": "known_value", "axis": "pitch",
          "parameter": {"name": "Mg", "value": 0.288, "unit": "N m", "table": 0.32}}
    assert finding_words(kv) == "Mg = 0.288 N m instead of 0.32 N m"
    # an effect a bench file cannot hold (declared elsewhere) is still named, with its parameter
    assert finding_words(_effect("wind_gust", "yaw", "g", 0.1, "N m")) == "wind_gust on yaw (g = 0.1 N m)"


def test_the_first_line_names_every_finding_in_one_sentence():
    cable = _effect("cable_stiffness", "yaw", "k", 0.004, "N m/rad")
    kv = {"effect": "known_value", "axis": "pitch",
          "parameter": {"name": "Mg", "value": 0.288, "unit": "N m", "table": 0.32}}
    assert headline("explained", [cable, kv]) == ("the model fits this log to its noise level with a cable on yaw "
                                                  "(k = 0.004 N m/rad) and Mg = 0.288 N m instead of 0.32 N m")
    assert headline("partly_explained", [cable]).startswith("a cable on yaw (k = 0.004 N m/rad) found, and the model "
                                                            "still misses something")
    assert headline("consistent", []) == HEADLINES["consistent"]
    # J/B not credible with the findings: leads, whether or not they reach the noise level (verdict.credible)
    assert headline("partly_explained", [cable], leads=True) == LEADS.format(found="a cable on yaw (k = 0.004 N m/rad)")
    assert "not measurements" in LEADS and "not credible" in LEADS and "still misses" not in LEADS
    assert listed(["a", "b", "c"]) == "a, b and c" and listed(["a"]) == "a"


def test_a_findings_lines_carry_one_fit_figure_its_interval_and_look_alikes_not_its_test_statistics():
    # #47 item 6: the evidence (t statistics, block counts, profiles) stays in diagnosis.json and the report
    from types import SimpleNamespace

    from trms_ident.diagnosis.result import Finding
    from trms_ident.report.terminal import diagnosis_lines

    evidence = "output-error fits over the modification's value: best at 0.2 (t = 9.1 over 18 blocks, p = 1e-9)"
    zone = Finding("dead_zone", "yaw", {"name": "w", "value": 0.2, "unit": "V", "ci95": [0.195, 0.205]}, 97.5, 99.9,
                   evidence, "the yaw motor ignores voltages below 0.2 V", 0.5, 9.1, 1e-9,
                   alternatives=["input_saturation:yaw"])
    cable = Finding("cable_stiffness", "yaw", {"name": "k", "value": 0.004, "unit": "N m/rad"}, 98.0, 99.97,
                    evidence, "the cable pulls the beam back", 0.9, 27.5, 1e-16)
    est = {"J1": 0.068, "B1": 0.006, "J2": 0.02, "B2": 0.1}
    d = SimpleNamespace(verdict="explained", findings=[zone, cable], verdict_sentence="both angles at their floors",
                        fit_before={"pitch": 99.7, "yaw": 97.5}, settings={"candidates": 20}, nominal=est,
                        augmented=est, held_out=None, refused=[], corrections=[],
                        with_findings={"estimates": est, "adequate": True, "text": "J1 0.068 [0.0679, 0.0681]",
                                       "values": {"cable_stiffness:yaw": {"estimate": 0.00401,
                                                                          "ci95": [0.00399, 0.00403]}}})
    text = "\n".join(diagnosis_lines(d, "log.csv"))
    assert "t = " not in text and "blocks" not in text and evidence not in text
    assert "  1. dead_zone on yaw: w = 0.2 V, 95 % [0.195, 0.205] V" in text
    assert "  2. cable_stiffness on yaw: k = 0.004 N m/rad\n" in text  # no interval of its own: none invented
    assert "this log cannot tell it apart from input_saturation:yaw" in text
    assert "the 2 s prediction fit of its axes: 97.50 % -> 99.90 %" in text
    assert "diagnosis.json" in text  # where the evidence is
    assert "cable_stiffness:yaw 0.00401 [0.00399, 0.00403]" in text  # fitted with J/B under the findings' model


def test_findings_whose_jb_are_not_credible_are_called_leads_on_the_first_line():
    # a weak-excitation log (the angles a random walk, the voltages within 10 mV): a 6 s second-order main motor
    # refitted J2 to 18.7 kg m^2; the first line said it was "found", and that the model "does not reach the noise
    # level" also where only credible() had turned "explained" into "partly explained"
    from types import SimpleNamespace

    from trms_ident.diagnosis.result import Finding
    from trms_ident.report.terminal import diagnosis_lines

    lag = Finding("motor_second_lag", "pitch", {"name": "T2", "value": 6.06, "unit": "s"}, 10.0, 40.0, "",
                  "a further lag", 0.3, 5.0, 1e-6)
    est = {"J1": 0.068, "B1": 0.006, "J2": 0.02, "B2": 0.1}
    d = SimpleNamespace(verdict="partly_explained", findings=[lag], verdict_sentence="far from this bench",
                        fit_before={"pitch": 10.0, "yaw": 5.0}, settings={"candidates": 20}, nominal=est,
                        augmented={**est, "J2": 18.7}, held_out=None, refused=[], corrections=[], with_findings=None)
    first = diagnosis_lines(d, "weak.csv")[0]
    assert first == ("weak.csv: PARTLY EXPLAINED: a second-order main motor (T2 = 6.06 s) found as leads to check, not "
                     "measurements: the J/B refitted with them are not credible (the findings' model is far from this "
                     "bench).")
    d.augmented = est  # credible: the plain partly-explained line
    assert "still misses something" in diagnosis_lines(d, "weak.csv")[0]
