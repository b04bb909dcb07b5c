"""How many of numba's threads a parallel stage runs on: those that have a core now.

Set for the calling thread alone (numba's thread count is per thread) and restored after
the stage; the process's settings are never changed.
"""

import contextlib
import os

import numba


def free_threads(threads: int, loadavg: str | None = None) -> int:
    """Return how many of ``threads`` have a core now: at least one.

    The cores this process may run on, less the tasks the system is running now besides
    the caller (the fourth field of ``/proc/loadavg``, ``running/total``; ``loadavg`` is
    that file's text, read when ``None``). Where that cannot be read, ``threads``. A
    parallel loop waits for its slowest thread at its end: on cores taken by other work,
    each of the few loops of a call would wait for the scheduler to give a core back (2.7x
    the one-thread time with both of two cores busy).
    """
    if threads <= 1:
        return 1
    try:
        if loadavg is None:
            with open("/proc/loadavg") as file:
                loadavg = file.read()
        running = int(loadavg.split()[3].split("/")[0])
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
    except (OSError, ValueError, IndexError):
        return threads
    cores = cores or os.cpu_count() or threads
    return max(1, min(threads, cores - (running - 1)))


@contextlib.contextmanager
def threads_with_cores():
    """Run the block with numba's thread count lowered to :func:`free_threads`'.

    Set for the calling thread alone (numba's count is per thread), restored at the end.
    """
    threads = numba.get_num_threads()
    numba.set_num_threads(free_threads(threads))
    try:
        yield
    finally:
        numba.set_num_threads(threads)
