"""The parameter table and TOML overrides."""
from pathlib import Path

import pytest

from trms_ident.errors import ParameterFileError
from trms_ident.params import PARAMETERS, implausible, load_parameter_file, marked, merge

PARAMETERS_PAGE = Path(__file__).resolve().parents[1] / "docs" / "parameters.md"


def test_every_parameter_is_documented_with_its_value_and_unit():
    text = PARAMETERS_PAGE.read_text(encoding="utf-8")
    missing = [p.name for p in PARAMETERS if f"| `{p.name}` | {p.value:g} | {p.unit} |" not in text]
    assert not missing, f"parameters missing or stale in docs/parameters.md: {missing}"


def test_toml_override_flat_and_table(tmp_path):
    f = tmp_path / "bench.toml"
    f.write_text("Mg = 0.3\n[parameters]\nkc = -0.25\n")
    assert load_parameter_file(f) == {"kc": -0.25}
    f.write_text("Mg = 0.3\nk1 = 1\n")
    assert merge(load_parameter_file(f))["Mg"] == 0.3


@pytest.mark.parametrize("content, message", [
    ("Mgg = 0.3\n", "unknown parameter 'Mgg'"),
    ("Mg = 'heavy'\n", "must be a finite number"),
    ("J1 = 0.07\n", "J1 given, but J1, B1, J2, B2 are the unknowns trms-ident estimates"),
    ("Mg = \n", "not valid TOML"),
])
def test_bad_parameter_files(tmp_path, content, message):
    f = tmp_path / "bad.toml"
    f.write_text(content)
    with pytest.raises(ParameterFileError, match=message) as info:
        load_parameter_file(f)
    assert str(f) in str(info.value)


def test_true_values_of_the_unknowns_only_for_the_simulator(tmp_path):
    f = tmp_path / "truth.toml"
    f.write_text("J1 = 0.08\nB2 = 0.12\n")
    assert load_parameter_file(f, allow_estimated=True) == {"J1": 0.08, "B2": 0.12}
    f.write_text("J1 = -1.0\n")
    with pytest.raises(ParameterFileError, match="J1 must be > 0"):
        load_parameter_file(f, allow_estimated=True)


def test_missing_parameter_file(tmp_path):
    with pytest.raises(ParameterFileError, match="parameter file not found"):
        load_parameter_file(tmp_path / "none.toml")


@pytest.mark.parametrize("name, value, expected", [
    ("J1", 0.05, None), ("J1", 0.068 * 99, None), ("B2", 1e-9, None),  # a friction may be tiny
    ("J1", 0.00437, None), ("J2", 0.00414, None), ("B1", 0.00184, None),  # the Humusoft CE150's
    ("J2", 6.47, "implausible: 324x Table 1's 0.02 kg m^2"),  # a real CE150 azimuth sweep's estimate
    ("J1", -0.3, "not physical"), ("B1", float("nan"), "not physical"), ("J2", 0.0, "not physical"),
    ("J1", 1.3e15, "implausible: 1.91e+16x Table 1's 0.068 kg m^2"),
    ("J2", 1e-4, "implausible: 0.005x Table 1's 0.02 kg m^2"),  # an inertia may not
    ("B2", 1258.0, "implausible: 1.26e+04x Table 1's 0.1 N m s/rad"),
])
def test_an_estimate_far_from_any_bench_is_called_so(name, value, expected):
    assert implausible(name, value) == expected
    assert marked(name, value) == f"{value:.6g}" + (f" ({expected})" if expected else "")


def test_a_bundled_bench_is_a_parameter_file_by_name(tmp_path):
    known = load_parameter_file("humusoft_ce150")
    assert known["Mg"] == 0.0383 and known["kc"] == 0.00162 and "J1" not in known  # [identified] is not known
    assert load_parameter_file("humusoft_ce150", allow_estimated=True)["J1"] == 0.00437  # simulate's truth
    with pytest.raises(ParameterFileError, match="nosuch: parameter file not found; expected a TOML file or a "
                                                 "bundled bench: humusoft_ce150"):
        load_parameter_file("nosuch")


def test_a_parameter_file_says_the_input_unit_its_known_values_take(tmp_path):
    from trms_ident.log import INPUTS_ASSUMED
    from trms_ident.params import declared_inputs, parameter_file_inputs_unit

    assert parameter_file_inputs_unit("humusoft_ce150").startswith("MU (the CE150's normalised machine units")
    flat = tmp_path / "flat.toml"
    flat.write_text('Mg = 0.3\n[units]\ninputs = "percent of full scale"\n')
    assert load_parameter_file(flat) == {"Mg": 0.3}  # [units] is no parameter
    assert parameter_file_inputs_unit(flat) == "percent of full scale"
    plain = tmp_path / "plain.toml"
    plain.write_text("Mg = 0.3\n")
    assert parameter_file_inputs_unit(plain) is None
    # the assumed volts give way to the declared unit; a unit the log itself gives stays
    assert declared_inputs({"inputs": INPUTS_ASSUMED}, "MU")["inputs"].startswith("MU (the unit the known values")
    assert declared_inputs({"inputs": "V (the file's units row)"}, "MU")["inputs"] == "V (the file's units row)"
    assert declared_inputs({"inputs": INPUTS_ASSUMED}, None)["inputs"] == INPUTS_ASSUMED


@pytest.mark.parametrize("name", ["T10", "T20"])
def test_a_motor_time_constants_s0_coefficient_of_zero_is_refused_in_one_line(tmp_path, name):
    # tau = k/(T11 s + T10) u: a T10 of 0 is an integrator, not eq. (1)'s motor; it had ended in an internal error
    # (a division by zero where the slowest time constant T11/T10 is taken)
    f = tmp_path / "bench.toml"
    f.write_text(f"[parameters]\n{name} = 0.0\n")
    with pytest.raises(ParameterFileError, match=f"{name} must be > 0, got 0.0"):
        load_parameter_file(f)
