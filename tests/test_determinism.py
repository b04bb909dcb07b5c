"""One input, one result: at 1 and 2 threads, and in a fresh process, for every method.

The methods run bands of rows in chunks whose number follows the thread count (one chunk
on one thread, up to four a thread otherwise); each chunk starts its sums afresh, so a
result that depended on the split would show here. The cases are every method of
``dcstereo.METHODS`` (a method added later is covered by this test as it is), each with
the Birchfield-Tomasi cost where it takes it, and the default method as ``match`` runs it
without ``method=``, with and without its post-processing.
"""

import inspect
import json
import os
import subprocess
import sys
import textwrap

import numba
import numpy as np
import pytest

import dcstereo
import synthetic
from method_cases import method_cases

DEFAULT_METHOD = inspect.signature(dcstereo.match).parameters["method"].default
MAX_DISPARITY = 12


#: (id, keyword arguments of match): ``method`` absent for the default.
CASES = method_cases(MAX_DISPARITY, bt={"cost": "bt"}) + [
    ("default", {}),
    ("default+post", {"subpixel": "parabola", "median": 3, "fill": True}),
]


def _pair():
    # 48 rows: six bands of 8, one chunk on one thread, six on two
    rng = np.random.default_rng(2024)
    left, right, _ = synthetic.object_pair(rng, 48, 64, 2, 9, (24, 44))
    return left, right


def _arrays(result):
    features = result.features if result.features is not None else np.empty((0, 5))
    return {
        "disparity": result.disparity,
        "flags": result.flags,
        "path_cost": result.path_cost,
        "features": features,
    }


FRESH_PROCESS = textwrap.dedent(
    """
    import json, sys
    import numba, numpy as np, dcstereo
    pair, dmax = np.load(sys.argv[1]), int(sys.argv[4])
    out = {}
    for name, options in json.loads(sys.argv[2]):
        for threads in (1, 2):
            numba.set_num_threads(threads)
            r = dcstereo.match(pair["left"], pair["right"], max_disparity=dmax, **options)
            features = r.features if r.features is not None else np.empty((0, 5))
            for key, value in (("disparity", r.disparity), ("flags", r.flags),
                               ("path_cost", r.path_cost), ("features", features)):
                out[f"{name}/{threads}/{key}"] = value
    np.savez(sys.argv[3], **out)
    """
)


@pytest.fixture(scope="module")
def fresh_results(tmp_path_factory):
    """Every case at 1 and 2 threads in a new process: ``{"case/threads/array": array}``."""
    # matched here first, so that the new process loads the kernels from numba's cache
    left, right = _pair()
    for _, options in CASES:
        dcstereo.match(left, right, max_disparity=MAX_DISPARITY, **options)
    folder = tmp_path_factory.mktemp("fresh")
    np.savez(folder / "pair.npz", left=left, right=right)
    env = {**os.environ, "NUMBA_NUM_THREADS": "2"}  # two threads even on a one-core machine
    subprocess.run(
        [sys.executable, "-c", FRESH_PROCESS, str(folder / "pair.npz"), json.dumps(CASES),
         str(folder / "out.npz"), str(MAX_DISPARITY)],
        env=env, check=True, timeout=1200,
    )  # fmt: skip
    with np.load(folder / "out.npz") as saved:
        return dict(saved)


def _at(threads, options):
    before = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        left, right = _pair()
        return _arrays(dcstereo.match(left, right, max_disparity=MAX_DISPARITY, **options))
    finally:
        numba.set_num_threads(before)


def _same(got, expected, what):
    for key in expected:
        assert got[key].dtype == expected[key].dtype, (what, key)
        assert got[key].shape == expected[key].shape, (what, key)
        assert got[key].tobytes() == expected[key].tobytes(), (what, key)


def test_the_cases_cover_every_method_and_the_default():
    assert {options.get("method", DEFAULT_METHOD) for _, options in CASES} == set(dcstereo.METHODS)
    assert DEFAULT_METHOD in dcstereo.METHODS


@pytest.mark.parametrize(("name", "options"), CASES, ids=[name for name, _ in CASES])
def test_one_and_two_threads_and_a_fresh_process_agree_bit_for_bit(name, options, fresh_results):
    one = _at(1, options)
    if numba.config.NUMBA_NUM_THREADS >= 2:
        _same(_at(2, options), one, "2 threads")
    _same(_at(1, options), one, "again")
    for threads in (1, 2):
        fresh = {key: fresh_results[f"{name}/{threads}/{key}"] for key in one}
        _same(fresh, one, f"a fresh process at {threads} threads")
