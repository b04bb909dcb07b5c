"""Repeated matches reuse their work buffers instead of page-faulting them again."""

import ctypes
import os
import subprocess
import sys
import textwrap

import pytest

from dcstereo import _memory


def _is_glibc():
    try:
        libc = ctypes.CDLL(None)
    except OSError:
        return False
    return sys.platform.startswith("linux") and hasattr(libc, "gnu_get_libc_version")


SCRIPT = textwrap.dedent(
    """
    import resource, numpy as np, numba, dcstereo
    numba.set_num_threads(1)
    rng = np.random.default_rng(0)
    right = rng.integers(0, 256, (375, 1800), dtype=np.uint8)
    left = np.roll(right, 7, axis=1)
    dcstereo.match(left, right, max_disparity=59, method="dsi5")
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range(3):
        dcstereo.match(left, right, max_disparity=59, method="dsi5")
    print((resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before) / 3)
    """
)


def _faults_per_call(keep_malloc):
    env = dict(os.environ)
    env.pop("DCSTEREO_KEEP_MALLOC", None)
    if keep_malloc:
        env["DCSTEREO_KEEP_MALLOC"] = "1"
    out = subprocess.run(
        [sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, check=True
    )
    return float(out.stdout.split()[-1])


@pytest.mark.skipif(not _is_glibc(), reason="the thresholds are glibc's (Linux only)")
def test_repeated_matches_do_not_page_fault_their_buffers():
    # an 1800 x 375 pair with 60 disparities on one thread (one band chunk): 3,000+ fresh
    # pages per call when glibc maps and unmaps the buffers each time (measured: 3,146;
    # 526 for 450 x 375, whose chunk's buffers are a quarter as wide), none when kept
    assert _memory.KEPT
    assert _faults_per_call(keep_malloc=False) < 200
    assert _faults_per_call(keep_malloc=True) > 1000  # the opt-out leaves glibc alone


def test_opt_out_leaves_the_allocator_alone(monkeypatch):
    monkeypatch.setenv("DCSTEREO_KEEP_MALLOC", "1")
    assert _memory.keep_work_buffers() is False
