"""The cyclic garbage collector is off while numba compiles (trms_ident/numerics/__init__.py says why)."""
import gc

from numba import njit
from numba.core import event

import trms_ident.numerics  # noqa: F401  (installs the guard)


def test_no_garbage_collection_while_numba_compiles_and_it_comes_back_after():
    seen = []

    class Record(event.Listener):
        def on_start(self, e):
            seen.append(gc.isenabled())

        def on_end(self, e):
            seen.append(gc.isenabled())

    listener = Record()
    event.register("numba:compile", listener)
    try:
        assert gc.isenabled()

        @njit
        def fresh(x):
            return x * 2 + 1

        assert fresh(3) == 7
    finally:
        event.unregister("numba:compile", listener)
    assert seen and not any(seen)
    assert gc.isenabled()
