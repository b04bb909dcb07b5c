"""MGM paths (``aggregation="mgm"``) against their twin (tests/naive_mgm.py)."""

import numpy as np
import pytest

import dcstereo
import naive_mgm
from dcstereo.kernels import mgm


@pytest.mark.parametrize("seed", range(3))
def test_mgm_equals_naive(seed):
    rng = np.random.default_rng(300 + seed)
    height, width, lanes, ndisp = 5, 7, 8, (4, 8, 6)[seed]
    cost = rng.integers(0, 300, (height, width, lanes)).astype(np.int16)
    luma = rng.integers(0, 4080, (height, width)).astype(np.int32)
    table = np.maximum(300 - np.arange(4081) // 8, 31).astype(np.int64)
    diagonals = seed != 1
    down = np.empty_like(cost)
    up = np.empty_like(cost)
    mgm.mgm_passes(cost, luma, 30, table, diagonals, ndisp, 32767, 16384, down, up)
    want_down, want_up = naive_mgm.mgm_sums(cost, luma, 30, table, diagonals, ndisp)
    np.testing.assert_array_equal(down[:, :, :ndisp], want_down)
    np.testing.assert_array_equal(up[:, :, :ndisp], want_up)
    assert (down[:, :, ndisp:] == 16384).all()


def test_mgm_by_hand():
    # 1 x 2 image, two disparities, P1 = 1, P2 = 5, flat luma. From above (one row, so
    # only the quadrant paths' horizontal predecessor): left to right, pixel 0: L = C =
    # (0, 4); pixel 1: message of (0, 4): (min(0, 4 + 1), min(4, 0 + 1)) - 0 = (0, 1),
    # C = (3, 0) -> (3, 1). Right to left, pixel 1: (3, 0); pixel 0: message (1, 0) + (0,
    # 4) = (1, 4). Down sums: pixel 0: (0 + 1, 4 + 4) = (1, 8); pixel 1: (3 + 3, 1 + 0).
    cost = np.array([[[0, 4], [3, 0]]], dtype=np.int16)
    luma = np.zeros((1, 2), dtype=np.int32)
    table = np.full(4081, 5, dtype=np.int64)
    down, up = np.empty_like(cost), np.empty_like(cost)
    mgm.mgm_passes(cost, luma, 1, table, False, 2, 32767, 16384, down, up)
    np.testing.assert_array_equal(down[0], [[1, 8], [6, 1]])
    np.testing.assert_array_equal(up[0], [[1, 8], [6, 1]])


def test_mgm_runs_in_sgm():
    rng = np.random.default_rng(11)
    left = rng.integers(0, 256, (24, 48)).astype(np.uint8)
    right = np.roll(left, -3, axis=1)
    result = dcstereo.match(left, right, max_disparity=8, aggregation="mgm")
    assert np.nanmedian(result.disparity[:, 10:]) == pytest.approx(3, abs=0.5)
