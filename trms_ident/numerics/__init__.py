"""Pure numerical core: arrays in, arrays or result objects out. No files, no printing."""

import gc as _gc
import threading as _threading

from numba.core import event as _event


class _NoCollectionWhileCompiling(_event.Listener):
    """The cyclic garbage collector stays off while numba holds its compiler lock.  Clean-clone test runs
    aborted a process ("Fatal Python error: Aborted", LLVM) three times with the collector running inside
    numba's compilation (copy_ir's deepcopy), once with one thread only; a collection deferred by a compile is
    run when the outermost compile ends."""

    def __init__(self):
        self._depth = 0
        self._was_enabled = False
        self._lock = _threading.Lock()

    def on_start(self, event):
        with self._lock:
            if self._depth == 0:
                self._was_enabled = _gc.isenabled()
                _gc.disable()
            self._depth += 1

    def on_end(self, event):
        with self._lock:
            self._depth -= 1
            if self._depth == 0 and self._was_enabled:
                _gc.enable()


_event.register("numba:compiler_lock", _NoCollectionWhileCompiling())
