"""How many of numba's threads a parallel stage runs on: those that have a core now.

Set for the calling thread alone (numba's thread count is per thread) and restored after
the stage; the process's settings are never changed.
"""

import contextlib
import os
import threading

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


def own_running(states: dict | None = None, callers: set | None = None) -> int:
    """Return how many threads of the caller's own work are running now (at least one).

    The caller and the threads of this process that are not Python threads (numba's
    workers): right after a parallel loop they still run for a moment (OpenMP's threads
    spin before they sleep), and ``/proc/loadavg`` counts them with other processes'. The
    process's other Python threads (other callers, each with its own parallel loops) stay
    other work. ``states``: each task's state (``R``: running), read from
    ``/proc/self/task`` when None; ``callers``: the native ids of the other Python threads,
    :func:`threading.enumerate`'s when None. 1 where the states cannot be read.
    """
    if callers is None:
        callers = {thread.native_id for thread in threading.enumerate()}
        callers.discard(threading.get_native_id())
    if states is None:
        states = _task_states()
    running = sum(state == "R" and task not in callers for task, state in states.items())
    return max(1, running)


def _task_states() -> dict:
    """Return ``{thread id: state}`` of this process's tasks (``/proc/self/task``; {} if none)."""
    states = {}
    try:
        tasks = os.listdir("/proc/self/task")
    except OSError:
        return states
    for task in tasks:
        try:
            with open(f"/proc/self/task/{task}/stat") as file:
                text = file.read()
        except OSError:  # a thread that ended meanwhile
            continue
        fields = text[text.rfind(")") + 1 :].split()  # after the name, which may hold spaces
        if task.isdigit() and fields:
            states[int(task)] = fields[0]
    return states


def free_threads(threads: int, loadavg: str | None = None, cpu_max: str | None = None,
                 own: int | None = None) -> int:  # fmt: skip
    """Return how many of ``threads`` have a core now: at least one.

    The cores this process may run on (its affinity, bounded by its control group's CPU
    quota, :func:`quota_cores`), less the tasks other processes are running now: the
    fourth field of ``/proc/loadavg`` (``running/total``) less this process's own running
    threads (``own``, :func:`own_running`: the caller, and numba's workers still spinning
    after the loop before). ``loadavg`` is that file's text and ``cpu_max`` the quota's,
    read when ``None``. Where the load cannot be read, ``threads`` bounded by the quota. A
    parallel loop waits for its slowest thread at its end: on cores taken by other work,
    each of the few loops of a call would wait for the scheduler to give a core back (2.7x
    the one-thread time with both of two cores busy).
    """
    if threads <= 1:
        return 1
    quota = quota_cores(cpu_max)
    if quota is not None:
        threads = min(threads, quota)
    if own is None:  # first: numba's workers may fall asleep while the load is read
        own = own_running()
    try:
        if loadavg is None:
            with open("/proc/loadavg") as file:
                loadavg = file.read()
        running = int(loadavg.split()[3].split("/")[0])
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
    except (OSError, ValueError, IndexError):
        return threads  # at least one: the quota is
    cores = cores or os.cpu_count() or threads
    others = max(0, running - own)
    return max(1, min(threads, cores - others))


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
