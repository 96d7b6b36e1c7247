"""The parameter table and TOML overrides."""
from pathlib import Path

import pytest

from trms_ident.errors import ParameterFileError
from trms_ident.params import PARAMETERS, load_parameter_file, merge

README = Path(__file__).resolve().parents[1] / "README.md"


def test_every_parameter_is_documented_in_the_readme():
    text = README.read_text(encoding="utf-8")
    missing = [p.name for p in PARAMETERS if f"| `{p.name}` |" not in text]
    assert not missing, f"parameters missing from the README table: {missing}"


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
