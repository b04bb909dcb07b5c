"""How many of numba's threads a parallel stage runs on: those that have a core now.

Set for the calling thread alone (numba's thread count is per thread) and restored after
the stage; the process's settings are never changed.
"""

import contextlib
import os

import numba

#: Where a Linux control group states the process's CPU quota: cgroup v2's ``cpu.max``
#: (``"<quota> <period>"`` or ``"max <period>"``), else cgroup v1's two files.
CGROUP_V2_MAX = "/sys/fs/cgroup/cpu.max"
CGROUP_V1_QUOTA = ("/sys/fs/cgroup/cpu/cpu.cfs_quota_us", "/sys/fs/cgroup/cpu/cpu.cfs_period_us")


def quota_cores(cpu_max: str | None = None) -> int | None:
    """Return the cores' worth of CPU time a control group allows this process, or None.

    A container started with ``--cpus=2`` on a 64-core host sees 64 cores but is given two
    cores' time: 64 threads would each wait for their share at the end of every parallel
    loop. ``cpu_max``: the text of cgroup v2's ``cpu.max`` (read, or cgroup v1's quota and
    period, when None); None where no quota is set or none can be read. Rounded up: a
    quota of 1.5 cores gives 2.
    """
    try:
        if cpu_max is None:
            try:
                with open(CGROUP_V2_MAX) as file:
                    cpu_max = file.read()
            except OSError:
                with open(CGROUP_V1_QUOTA[0]) as quota, open(CGROUP_V1_QUOTA[1]) as period:
                    cpu_max = f"{quota.read().strip()} {period.read().strip()}"
        quota, period = cpu_max.split()[:2]
        if quota == "max" or int(quota) <= 0:  # v1 writes -1 for no quota
            return None
        return max(1, -(-int(quota) // int(period)))
    except (OSError, ValueError, ZeroDivisionError):
        return None


def free_threads(threads: int, loadavg: str | None = None, cpu_max: str | None = None) -> int:
    """Return how many of ``threads`` have a core now: at least one.

    The cores this process may run on (its affinity, bounded by its control group's CPU
    quota, :func:`quota_cores`), less the tasks the system is running now besides the
    caller (the fourth field of ``/proc/loadavg``, ``running/total``; ``loadavg`` is that
    file's text and ``cpu_max`` the quota's, read when ``None``). Where the load cannot be
    read, ``threads`` bounded by the quota. A parallel loop waits for its slowest thread at
    its end: on cores taken by other work, each of the few loops of a call would wait for
    the scheduler to give a core back (2.7x the one-thread time with both of two cores busy).
    """
    if threads <= 1:
        return 1
    quota = quota_cores(cpu_max)
    if quota is not None:
        threads = min(threads, quota)
    try:
        if loadavg is None:
            with open("/proc/loadavg") as file:
                loadavg = file.read()
        running = int(loadavg.split()[3].split("/")[0])
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
    except (OSError, ValueError, IndexError):
        return threads  # at least one: the quota is
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
