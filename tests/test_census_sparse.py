"""The sparse census (``census_step``) against its twin (tests/naive_census_sparse.py)."""

import numpy as np
import pytest

import dcstereo
import naive_census_sparse
import naive_sgm
from dcstereo.methods import sgm
from dcstereo.params import MatchParams


@pytest.mark.parametrize(("rows", "cols", "step"), [(3, 3, 2), (5, 5, 2), (3, 5, 3), (5, 5, 1)])
def test_sparse_census_equals_naive(rows, cols, step):
    rng = np.random.default_rng(rows * 10 + step)
    signal = rng.integers(0, 4000, (11, 14)).astype(np.int32)
    out = np.empty((11, 14), dtype=np.uint32)
    sgm._census(signal, rows, cols, out, step)
    np.testing.assert_array_equal(out, naive_census_sparse.sparse_census(signal, rows, cols, step))


def test_step_one_is_the_dense_census():
    rng = np.random.default_rng(5)
    signal = rng.integers(0, 4000, (9, 12)).astype(np.int32)
    out = np.empty((9, 12), dtype=np.uint32)
    sgm._census(signal, 5, 5, out, 1)
    np.testing.assert_array_equal(out, naive_sgm.census(signal, 5, 5))


def test_sparse_census_by_hand():
    # Row 5 9 1 7 3, a 1 x 3 census with step 2. At x = 2 (value 1): samples x = 0 (5)
    # and x = 4 (3), neither darker -> 00. At x = 1 (9): x = -1 repeats the edge (5,
    # darker) and x = 3 (7, darker) -> 11 = 3.
    signal = np.array([[5, 9, 1, 7, 3]], dtype=np.int32)
    out = np.empty((1, 5), dtype=np.uint32)
    sgm._census(signal, 1, 3, out, 2)
    assert out[0, 2] == 0
    assert out[0, 1] == 3


def test_sparse_census_bits_and_costs():
    params = MatchParams(max_disparity=4, census_window=(5, 7), census_step=2)
    assert sgm.census_bit_cost(params.census_window) == 3  # round(96 / 34 bits)
    assert sgm.largest_pixel_cost(params) == 3 * 34 + 20  # the sparse code has as many bits
    default = MatchParams(max_disparity=4)
    assert sgm.largest_pixel_cost(default) == sgm.census_bit_cost((5, 5)) * 24 + 20
    with pytest.raises(ValueError, match="census_step"):
        MatchParams(max_disparity=4, census_step=5)


def test_sparse_census_runs_in_sgm():
    rng = np.random.default_rng(9)
    left = rng.integers(0, 256, (24, 48)).astype(np.uint8)
    right = np.roll(left, -3, axis=1)
    for options in (
        {"census_step": 2},
        {"census_window": (5, 7), "census_step": 2, "cost": "census", "p1": 80, "p2": 500},
    ):
        result = dcstereo.match(left, right, max_disparity=8, **options)
        assert np.nanmedian(result.disparity[:, 10:]) == pytest.approx(3, abs=0.5)
