"""The hand-written vector code against numba's compilation of its plain forms, whole methods.

``DCSTEREO_VECTOR=0`` compiles the plain form of every vector operation
(:mod:`dcstereo._vector`); a target without AVX-512 (forced through numba's
``NUMBA_CPU_NAME`` / ``NUMBA_CPU_FEATURES``) compiles the narrow branches (``_CARRY``,
``_PINS_IN_LOOP``, 4-lane forms) that this machine would never run. Each runs every method
that uses vector code in a fresh process, and its maps must equal this process's, bit for bit.
"""

import inspect
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import dcstereo
from dcstereo._vector import simd

#: An AVX2 machine (Haswell) as numba names its features.
AVX2 = (
    "+64bit,+avx,+avx2,+bmi,+bmi2,+cmov,+cx16,+f16c,+fma,+fsgsbase,+lzcnt,+mmx,+movbe,"
    "+popcnt,+sse,+sse2,+sse3,+sse4.1,+sse4.2,+ssse3,+xsave"
)

CASES = [
    ("sgm", {}),
    ("sgm", {"colour": True}),
    ("dc", {}),
    ("dc", {"cost": "bt"}),
    ("dsi5", {}),
    ("dsi3", {"cost": "bt"}),
    ("dsi3-gcp", {}),
    ("block", {}),
]

_SCRIPT = """
import json, sys
import numpy as np
import dcstereo
from dcstereo._vector import VECTOR, simd
cases = json.loads(sys.argv[1])
out = {"vector": VECTOR, "wide": simd._wide_vectors()}
for i, (method, options) in enumerate(cases):
    left, right = pair(options.pop("colour", False))
    result = dcstereo.match(left, right, max_disparity=9, method=method, **options)
    out[str(i)] = [result.disparity.tobytes().hex(), result.flags.tobytes().hex()]
print(json.dumps(out))
"""


def pair(colour=False):
    rng = np.random.default_rng(11)
    right = rng.integers(0, 256, (37, 61, 3) if colour else (37, 61), dtype=np.uint8)
    left = np.roll(right, 4, axis=1)
    left[10:20, 20:35] = np.roll(right, 7, axis=1)[10:20, 20:35]  # a nearer patch
    return left, right


def _run(env_extra):
    source = inspect.getsource(pair) + _SCRIPT
    env = {**os.environ, **env_extra}
    if "NUMBA_CPU_NAME" in env_extra:  # NUMBA_CACHE_DIR: set by the conftest
        # kernels for another processor: a cache folder of their own, out of the way of the
        # run's (the plain forms have theirs, dcstereo._vector._cache.PLAIN_FOLDER)
        env["NUMBA_CACHE_DIR"] = os.path.join(os.environ["NUMBA_CACHE_DIR"], "avx2-target")
    done = subprocess.run(
        [sys.executable, "-c", source, json.dumps(CASES)],
        env=env,
        capture_output=True,
        text=True,
        timeout=1800,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def _here():
    out = {}
    for i, (method, options) in enumerate(CASES):
        options = dict(options)
        left, right = pair(options.pop("colour", False))
        result = dcstereo.match(left, right, max_disparity=9, method=method, **options)
        out[str(i)] = [result.disparity.tobytes().hex(), result.flags.tobytes().hex()]
    return out


@pytest.mark.slow
@pytest.mark.early
@pytest.mark.parametrize(
    ("env", "vector", "wide"),
    [
        ({"DCSTEREO_VECTOR": "0"}, False, None),
        ({"NUMBA_CPU_NAME": "haswell", "NUMBA_CPU_FEATURES": AVX2}, True, False),
    ],
    ids=["plain-forms", "avx2-target"],
)
def test_every_method_gives_the_same_maps(env, vector, wide):
    if wide is False and not simd._wide_vectors():
        pytest.skip("no AVX-512 here: the whole suite runs the narrow forms on this machine")
    theirs = _run(env)
    assert theirs.pop("vector") is vector
    target_wide = theirs.pop("wide")
    if wide is not None:
        assert target_wide is wide
    ours = _here()
    for i, (method, options) in enumerate(CASES):
        assert theirs[str(i)] == ours[str(i)], (method, options)


def test_the_suite_runs_the_vector_forms():
    import dcstereo._vector as vector

    assert vector.VECTOR is True
