"""The suite's own bookkeeping: the long scenarios left out of the README's test command still exist."""
from pathlib import Path

from .conftest import LONG, SLOW, slow_key


def test_every_slow_and_long_entry_names_a_test_of_the_suite():
    here = Path(__file__).parent
    for key in [*SLOW, *LONG]:
        file, name = key.split("::")
        assert f"def {name.split('[')[0]}(" in (here / file).read_text(), key
    assert slow_key("tests/test_mat.py::test_x[a-b]") == "test_mat.py::test_x[a-b]"
