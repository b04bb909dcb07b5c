"""The guided cost filter and the sparse census against their twins (tests/naive_guided.py)."""

import numpy as np
import pytest

import dcstereo
import naive_guided
from dcstereo import sgm
from dcstereo.kernels import guided


@pytest.mark.parametrize("seed", range(3))
def test_guided_filter_equals_naive(seed):
    rng = np.random.default_rng(200 + seed)
    height, width, lanes, ndisp = 9, 12, 8, (5, 8, 3)[seed]
    radius, eps = (1, 2, 3)[seed], (1e-4, 1e-2, 1.0)[seed]
    guide = rng.random((height, width))
    volume = rng.integers(0, 350, (height, width, lanes)).astype(np.int16)
    want = naive_guided.guided_filter(volume, guide, ndisp, radius, eps)
    got = volume.copy()
    guided.guided_filter(got, guide, ndisp, radius, eps)
    # float sums in another order: a rounding may fall on the other side of .5, rarely
    assert np.abs(got.astype(int) - want).max() <= 1
    assert np.mean(got == want) > 0.99
    np.testing.assert_array_equal(got[:, :, ndisp:], volume[:, :, ndisp:])


def test_guided_filter_by_hand():
    # A flat guide (variance 0): a = 0, b = mean(p), q = the box mean of the box mean.
    # One row 0, 3, 6 with radius 1: means 1.5, 3, 4.5; again: 2.25, 3, 3.75 -> 2, 3, 4.
    volume = np.array([[[0], [3], [6]]], dtype=np.int16)
    guided.guided_filter(volume, np.zeros((1, 3)), 1, 1, 1e-4)
    np.testing.assert_array_equal(volume[0, :, 0], [2, 3, 4])
    # A guide that follows p exactly (p = 100 I): q = p, the edge kept.
    guide = np.array([[0.0, 0.0, 1.0, 1.0]])
    volume = np.array([[[0], [0], [100], [100]]], dtype=np.int16)
    guided.guided_filter(volume, guide, 1, 1, 1e-9)
    np.testing.assert_array_equal(volume[0, :, 0], [0, 0, 100, 100])


@pytest.mark.parametrize(("rows", "cols", "step"), [(3, 3, 2), (5, 5, 2), (3, 5, 3), (5, 5, 1)])
def test_sparse_census_equals_naive(rows, cols, step):
    rng = np.random.default_rng(rows * 10 + step)
    signal = rng.integers(0, 4000, (11, 14)).astype(np.int32)
    out = np.empty((11, 14), dtype=np.uint32)
    sgm._census(signal, rows, cols, out, step)
    np.testing.assert_array_equal(out, naive_guided.sparse_census(signal, rows, cols, step))


def test_sparse_census_by_hand():
    # 1 x 5 row 5 9 1 7 3, a 1 x 3 census with step 2 at x = 2 (value 1): samples x = 0
    # (5, not darker) and x = 4 (3, not darker) -> 00; at x = 1 (9): x = -1 -> 5 (edge,
    # darker), x = 3 -> 7 (darker) -> 11 = 3.
    signal = np.array([[5, 9, 1, 7, 3]], dtype=np.int32)
    out = np.empty((1, 5), dtype=np.uint32)
    sgm._census(signal, 1, 3, out, 2)
    assert out[0, 2] == 0
    assert out[0, 1] == 3


def test_guided_and_sparse_run_in_sgm():
    rng = np.random.default_rng(9)
    left = rng.integers(0, 256, (24, 48)).astype(np.uint8)
    right = np.roll(left, -3, axis=1)
    for options in ({"aggregation": "guided"}, {"census_step": 2}):
        result = dcstereo.match(left, right, max_disparity=8, **options)
        assert np.nanmedian(result.disparity[:, 10:]) == pytest.approx(3, abs=0.5)
