"""One numba cache for every process of the test run, each kernel compiled once.

The suite runs on several pytest-xdist workers, and tests start processes of their own
(the command line, the scripts, Dask's workers). Each used to keep a cache folder of its
own, because two processes saving entries of one function's cache index at once can pair
a signature with another's machine code (numba#4807): so every worker compiled every
kernel, most of the suite's time on a clean clone.

:func:`install` makes the processes share one folder safely: it wraps
``Dispatcher.compile`` of a cached function in an exclusive ``flock`` on a file beside the
function's index. The lock is held from the look into the cache to the save, so a process
that wants a kernel another is compiling waits and then loads it, and no two processes
ever choose data files for one index at once. Locks are taken inside numba's compiler
lock, in the order of the calls (a caller, then the callees it compiles), so they cannot
deadlock. The conftest installs it in the workers; ``sitecustomize.py`` beside this file
installs it in the Python processes the tests start (``DCSTEREO_TEST_CACHE_LOCK=1``).
This is test machinery: the library itself never changes numba.
"""

import fcntl
import os
import time

#: Seconds a process waits for another's compile of one function before it gives up with
#: an error (a hang would be worse): no kernel compiles for anywhere near this long.
WAIT_SECONDS = 1200

_held: set[str] = set()


def _lock(lock, path):
    deadline = time.monotonic() + WAIT_SECONDS
    while True:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return
        except BlockingIOError:
            if time.monotonic() > deadline:
                raise RuntimeError(f"waited {WAIT_SECONDS} s for {path}") from None
            time.sleep(0.02)


def install() -> None:
    """Wrap ``Dispatcher.compile`` of this process (once)."""
    from numba.core import dispatcher
    from numba.core.compiler_lock import global_compiler_lock

    compile_ = dispatcher.Dispatcher.compile
    if getattr(compile_, "_kernel_cache_lock", False):
        return

    def compile(self, sig):
        cache_file = getattr(getattr(self, "_cache", None), "_cache_file", None)
        if cache_file is None:  # not cached: nothing shared
            return compile_(self, sig)
        with global_compiler_lock:  # one thread of this process at a time
            path = cache_file._index_path + ".lock"
            if path in _held:  # this function is being compiled up the stack
                return compile_(self, sig)
            os.makedirs(os.path.dirname(path), exist_ok=True)
            with open(path, "a") as lock:
                _lock(lock, path)  # released when the file closes
                _held.add(path)
                try:
                    return compile_(self, sig)
                finally:
                    _held.discard(path)

    compile._kernel_cache_lock = True
    dispatcher.Dispatcher.compile = compile
