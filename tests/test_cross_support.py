"""Cross-based aggregation (``aggregation="cross"``) against its twin (tests/naive_cross.py)."""

import numpy as np
import pytest

import dcstereo
import naive_cross
from dcstereo.aggregate import _cross as kernels
from dcstereo.aggregate.cross import cross_aggregate, support_arms


def test_arms_by_hand():
    # One row, one channel: 10 10 12 40 41 41 41 90; tau1 = 5, limit1 = 4 (arms of at most
    # 3), limit2 = 2 and tau2 = round(0.3 * 5) = 2 past it. Pixel 0's right arm: 10, 12
    # join (within 5 of it and of the previous pixel), 40 stops it -> 2. Pixel 3 (40):
    # 41, 41 join, and 41 at t = 3 (> limit2) is within tau2 -> 3. Pixel 4 (41): left 40
    # joins, 12 stops -> 1; right 41, 41, then 90 stops -> 2.
    colour = np.array([[[10, 10, 12, 40, 41, 41, 41, 90]]], dtype=np.int16)
    arms = support_arms(colour, 4, 5)  # tight bound 2 beyond limit // 2 = 2 pixels
    np.testing.assert_array_equal(arms[0, 0], [0, 1, 2, 0, 1, 2, 3, 0])
    np.testing.assert_array_equal(arms[1, 0], [2, 1, 0, 3, 2, 1, 0, 0])
    assert not arms[2:].any()  # one row: no vertical arms


def test_arms_tight_bound_by_hand():
    # 0 3 6 9: tau1 = 10 lets every step through; limit1 = 8, limit2 = 1, tau2 = 4 (of
    # tau 13 -> round(3.9) = 4): pixel 0's right arm takes 3 (t = 1, within limit2), then
    # 6 (t = 2 > limit2: |6 - 0| >= 4) stops it.
    colour = np.array([[[0, 3, 6, 9]]], dtype=np.int16)
    arms = np.empty((4, 1, 4), np.int32)
    kernels.cross_arms(colour, 8, 1, 13, 4, arms)
    assert arms[1, 0, 0] == 1
    assert arms[1, 0, 1] == 1  # 6 joins (3 < 4), then 9 at t = 2: |9 - 3| = 6 >= 4
    assert arms[0, 0, 3] == 1


def test_aggregation_by_hand():
    # Row of 3 pixels all alike (one region), one disparity: costs 1, 2, 6 -> mean 3 each.
    volume = np.array([[[1, 100], [2, 100], [6, 100]]], dtype=np.int16)
    colour = np.zeros((1, 1, 3), dtype=np.int16)
    cross_aggregate(volume, colour, 1, limit=10, tau=20, iterations=1)
    np.testing.assert_array_equal(volume[0, :, 0], [3, 3, 3])
    np.testing.assert_array_equal(volume[0, :, 1], [100, 100, 100])  # padding lane untouched
    # Rounded to nearest: 1, 2 -> 1.5 -> 2.
    volume = np.array([[[1], [2]]], dtype=np.int16)
    cross_aggregate(volume, np.zeros((1, 1, 2), np.int16), 1, limit=10, tau=20, iterations=1)
    np.testing.assert_array_equal(volume[0, :, 0], [2, 2])


@pytest.mark.parametrize("seed", range(4))
def test_arms_equal_naive(seed):
    rng = np.random.default_rng(seed)
    channels = (1, 3)[seed % 2]
    # Smooth-ish colours so that arms grow: a few levels of random steps.
    colour = rng.integers(0, 4, (channels, 9, 13)).cumsum(axis=2).astype(np.int16) * 3
    limit, tau = (5, 9, 17, 3)[seed], (6, 12, 20, 40)[seed]
    got = support_arms(colour, limit, tau)
    want = naive_cross.arms(colour, limit, limit // 2, tau, max(1, round(0.3 * tau)))
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("seed", range(4))
def test_aggregation_equals_naive(seed):
    rng = np.random.default_rng(100 + seed)
    height, width, lanes, ndisp = 7, 11, 8, (5, 8, 3, 6)[seed]
    colour = rng.integers(0, 3, (3, height, width)).cumsum(axis=1).astype(np.int16) * 4
    volume = rng.integers(0, 350, (height, width, lanes)).astype(np.int16)
    limit, tau, iterations = (4, 6, 9, 30)[seed], (10, 15, 20, 30)[seed], (1, 2, 3, 4)[seed]
    want = naive_cross.cross_aggregate(volume.copy(), colour, ndisp, limit, tau, iterations)
    got = volume.copy()
    cross_aggregate(got, colour, ndisp, limit=limit, tau=tau, iterations=iterations)
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("seed", range(4))
def test_both_views_aggregation_equals_naive(seed):
    rng = np.random.default_rng(400 + seed)
    height, width, lanes, ndisp = 6, 12, 8, (5, 8, 3, 6)[seed]
    dmin = (0, 0, -2, 3)[seed]
    colour = rng.integers(0, 3, (3, height, width)).cumsum(axis=2).astype(np.int16) * 4
    colour_r = np.roll(colour, -2, axis=2)
    colour_r[:, :, -2:] = rng.integers(0, 60, (3, height, 2))
    volume = rng.integers(0, 350, (height, width, lanes)).astype(np.int16)
    limit, tau, iterations = (4, 6, 9, 5)[seed], (10, 15, 20, 30)[seed], (1, 2, 3, 1)[seed]
    want = naive_cross.cross_aggregate_both(
        volume.copy(), colour, colour_r, dmin, ndisp, limit, tau, iterations
    )
    got = volume.copy()
    cross_aggregate(
        got, colour, ndisp, limit=limit, tau=tau, iterations=iterations, colour_r=colour_r,
        dmin=dmin,
    )  # fmt: skip
    np.testing.assert_array_equal(got, want)


def test_both_views_by_hand():
    # One row of 4, disparities 0 and 1. Left: all alike (arms to the row's ends); right:
    # 0 0 | 90 90, arms (left, right) (0, 1), (1, 0), (0, 1), (1, 0). A pair's arm is the
    # shorter of the two on each side. d = 0: x = 0 and 1 average x = 0..1 (3), x = 2 and 3
    # x = 2..3 (7). d = 1 (right pixel x - 1, clamped): x = 0 with right 0: 0..1 (3);
    # x = 1 with right 0: 1..2 (5); x = 2 with right 1: 1..2 (5); x = 3 with right 2: its
    # left arm min(3, 0) = 0 and right min(0, 1) = 0: alone (8).
    colour = np.zeros((1, 1, 4), np.int16)
    colour_r = np.array([[[0, 0, 90, 90]]], np.int16)
    volume = np.array([[[2, 2], [4, 4], [6, 6], [8, 8]]], np.int16)
    cross_aggregate(volume, colour, 2, limit=10, tau=20, iterations=1, colour_r=colour_r)
    np.testing.assert_array_equal(volume[0, :, 0], [3, 3, 7, 7])
    np.testing.assert_array_equal(volume[0, :, 1], [3, 5, 5, 8])


def test_default_sgm_unchanged_and_cross_runs():
    rng = np.random.default_rng(7)
    left = rng.integers(0, 256, (20, 40)).astype(np.uint8)
    right = np.roll(left, -3, axis=1)
    plain = dcstereo.match(left, right, max_disparity=8)
    same = dcstereo.match(left, right, max_disparity=8, aggregation=None)
    np.testing.assert_array_equal(plain.disparity, same.disparity)
    crossed = dcstereo.match(left, right, max_disparity=8, aggregation="cross")
    assert np.nanmedian(crossed.disparity[:, 10:]) == pytest.approx(3, abs=0.5)


def test_cross_options_refused_elsewhere():
    with pytest.raises(ValueError, match="aggregation"):
        dcstereo.MatchParams(max_disparity=4, aggregation="box")
    with pytest.raises(ValueError, match="cross_limit"):
        dcstereo.MatchParams(max_disparity=4, aggregation="cross", cross_limit=0)
    with pytest.raises(ValueError):
        dcstereo.MatchParams(max_disparity=4, method="block", aggregation="cross")
