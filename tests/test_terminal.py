"""diagnose's terminal words (report/terminal.py, issue #47 item 6): the verdict and the findings in plain words
first, the same words in batch's summary; pure, on diagnosis.json-shaped findings."""
from trms_ident.report.terminal import HEADLINES, finding_words, headline, listed


def _effect(effect, axis, name, value, unit):
    return {"effect": effect, "axis": axis, "parameter": {"name": name, "value": value, "unit": unit}}


def test_each_kind_of_finding_reads_as_words_with_its_value_and_unit():
    assert finding_words(_effect("cable_stiffness", "yaw", "k", 0.004, "N m/rad")) == "a cable on yaw (k = 0.004 N m/rad)"
    assert finding_words(_effect("motor_second_lag", "yaw", "T2", 0.463, "s")) == \
        "a second-order tail motor (T2 = 0.463 s)"
    assert finding_words(_effect("dead_zone", "pitch", "w", 0.25, "V")) == "a dead zone on the main motor (w = 0.25 V)"
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
    assert listed(["a", "b", "c"]) == "a, b and c" and listed(["a"]) == "a"
