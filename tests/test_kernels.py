"""The compiled kernels against their naive twins in ``naive.py``."""

import math

import numpy as np
import pytest

import naive
from dcstereo import _records as records
from dcstereo.costs import window as costs
from dcstereo.divide import divide
from dcstereo.result import FLAG_FEATURE
from dcstereo.scanline import dp

STEP_NAMES = {
    dp.STEP_C: naive.C,
    dp.STEP_A: naive.A,
    dp.STEP_B: naive.B,
    dp.STEP_D: naive.D,
    dp.STEP_E: naive.E,
}


def run_dp(cost, dmin, occ, five, box, anchor_start=False, anchor_end=False):
    """Call ``scanline_dp``; return (total, nodes, steps) in the oracle's format."""
    width, ndisp = cost.shape
    x_lo, x_hi, j_lo, j_hi = box
    path = dp.path_scratch(width, ndisp)
    n, total = dp.scanline_dp(
        cost,
        dmin,
        records.step_costs(2.0 * occ, 0.0, five),
        x_lo,
        x_hi,
        j_lo,
        j_hi,
        anchor_start,
        anchor_end,
        path,
    )
    path_x, path_k, path_s = path.path_x, path.path_k, path.path_s
    if n == 0:
        return math.inf, [], []
    xs = path_x[:n][::-1]
    ks = path_k[:n][::-1]
    ss = path_s[:n][::-1]
    nodes = [(int(x), int(x - dmin - k)) for x, k in zip(xs, ks, strict=True)]
    names = [STEP_NAMES.get(int(s)) for s in ss]
    if anchor_start:
        assert ss[0] == dp.STEP_START
        return total / 2.0, nodes, names[1:]
    # prepend the virtual start node the first step came from
    di, dj = naive._MOVES[names[0]]
    nodes.insert(0, (nodes[0][0] - di, nodes[0][1] - dj))
    return total / 2.0, nodes, names


def random_band(rng, width, dmin, ndisp, high=20):
    """A random integer banded DSI with inf where the right pixel leaves the image."""
    cost = rng.integers(0, high, size=(width, ndisp)).astype(np.float64)
    for x in range(width):
        for k in range(ndisp):
            if not 0 <= x - dmin - k < width:
                cost[x, k] = np.inf
    return cost


@pytest.mark.parametrize("five", [False, True], ids=["dsi3", "dsi5"])
@pytest.mark.parametrize("seed", range(12))
def test_whole_scanline_dp_matches_oracle(five, seed):
    rng = np.random.default_rng(1000 + seed)
    width = int(rng.integers(2, 7))
    ndisp = int(rng.integers(1, min(width, 4) + 1))
    dmin = int(rng.integers(-1, 2))
    if dmin + ndisp - 1 >= width:
        dmin = width - ndisp
    cost = random_band(rng, width, dmin, ndisp)
    occ = float(rng.integers(1, 15))
    box = (0, width - 1, 0, width - 1)
    expected = naive.best_path_cost(cost, dmin, occ, five, box)
    total, nodes, steps = run_dp(cost, dmin, occ, five, box)
    assert total == expected
    assert naive.path_is_admissible(nodes, steps, cost, dmin, occ, five, box, False, False) == (
        pytest.approx(total)
    )


@pytest.mark.parametrize("five", [False, True], ids=["dsi3", "dsi5"])
@pytest.mark.parametrize("seed", range(12))
def test_anchored_rectangle_dp_matches_oracle(five, seed):
    rng = np.random.default_rng(2000 + seed)
    width, ndisp, dmin = 9, 4, 0
    cost = random_band(rng, width, dmin, ndisp)
    x_lo = int(rng.integers(2, 4))
    x_hi = int(rng.integers(x_lo + 1, min(x_lo + 5, width - 1) + 1))
    j_lo = x_lo - int(rng.integers(0, ndisp))
    j_hi = x_hi - int(rng.integers(0, ndisp))
    j_hi = max(j_hi, j_lo + 1)
    if not dmin <= x_hi - j_hi < dmin + ndisp:
        j_hi = x_hi - dmin
    box = (x_lo, x_hi, j_lo, j_hi)
    occ = float(rng.integers(1, 15))
    for anchor_end in (False, True):
        expected = naive.best_path_cost(cost, dmin, occ, five, box, True, anchor_end)
        total, nodes, steps = run_dp(cost, dmin, occ, five, box, True, anchor_end)
        assert total == expected, (box, anchor_end)
        if expected < math.inf:
            cost_of_path = naive.path_is_admissible(
                nodes, steps, cost, dmin, occ, five, box, True, anchor_end
            )
            assert cost_of_path == pytest.approx(total)
        else:
            assert nodes == []


def test_anchored_end_without_any_path_reports_none():
    # the end cell is outside the band: no path can reach it
    cost = np.zeros((6, 2))
    total, nodes, _ = run_dp(cost, 0, 1.0, True, (0, 5, 0, 1), True, True)
    assert total == math.inf and nodes == []


@pytest.mark.parametrize("radius", [0, 1, 2])
def test_row_costs_match_naive_window_sad(radius):
    rng = np.random.default_rng(7)
    height, width, dmin, ndisp = 6, 11, -2, 5
    left = rng.integers(0, 4096, size=(height, width)).astype(np.int32)
    right = rng.integers(0, 4096, size=(height, width)).astype(np.int32)
    pad = ((radius, radius), (radius, radius))
    left_p, right_p = np.pad(left, pad, mode="edge"), np.pad(right, pad, mode="edge")
    out = np.empty((width, ndisp))
    fresh = np.empty((width, ndisp))
    vcol = np.empty((width, ndisp), dtype=np.int32)
    vcol_fresh = np.empty((width, ndisp), dtype=np.int32)
    for y in range(height):
        # rows after the first update the vertical sums of the row before
        costs.row_costs(left_p, right_p, y, dmin, ndisp, radius, vcol, out, y > 0)
        costs.row_costs(left_p, right_p, y, dmin, ndisp, radius, vcol_fresh, fresh, False)
        expected = naive.row_costs(left, right, y, dmin, ndisp, radius)
        np.testing.assert_array_equal(out, expected)
        np.testing.assert_array_equal(fresh, expected)


@pytest.mark.parametrize("dmin", [-12, -3, 0, 4, 11])
def test_row_costs_match_naive_when_the_band_leaves_the_image(dmin):
    # disparities beyond the width: whole rows of the band are outside the image
    rng = np.random.default_rng(11)
    height, width, ndisp, radius = 4, 9, 6, 2
    left = rng.integers(0, 4096, size=(height, width)).astype(np.int32)
    right = rng.integers(0, 4096, size=(height, width)).astype(np.int32)
    pad = ((radius, radius), (radius, radius))
    left_p, right_p = np.pad(left, pad, mode="edge"), np.pad(right, pad, mode="edge")
    out = np.empty((width, ndisp))
    vcol = np.empty((width, ndisp), dtype=np.int32)
    for y in range(height):
        costs.row_costs(left_p, right_p, y, dmin, ndisp, radius, vcol, out, y > 0)
        np.testing.assert_array_equal(out, naive.row_costs(left, right, y, dmin, ndisp, radius))


def test_oracle_enumerates_the_hand_counted_paths():
    # 2 x 2 DSI, one disparity (0): the only cells are (0,0) and (1,1); from the virtual
    # start (-1,-1) the only paths are c,c. A second disparity adds the a/b detours.
    cost = np.array([[1.0], [2.0]])
    paths = list(naive.enumerate_paths(cost, 0, 5.0, False, (0, 1, 0, 1)))
    totals = sorted(t for t, _, _ in paths)
    # the only virtual start in the band is (-1, -1); the only path is c, c = 1 + 2
    assert totals == [3.0]
    cost = np.array([[1.0, np.inf], [2.0, 4.0]])
    paths = list(naive.enumerate_paths(cost, 0, 5.0, False, (0, 1, 0, 1)))
    # starts (-1, -1) (d = 0) and (0, -1) (d = 1). From (-1, -1): c c = 3; c a = 6, then
    # b = 11. From (0, -1): c to (1, 0) = 4, then b = 9; b to (0, 0) = 5, then c = 7, or
    # a = 10, then b = 15. Every node with i == 1 or j == 1 ends a path.
    totals = sorted(t for t, _, _ in paths)
    assert totals == [3.0, 4.0, 6.0, 7.0, 9.0, 10.0, 11.0, 15.0]


@pytest.mark.parametrize("with_scores", [True, False])
def test_collect_features_equals_numpy_nonzero(with_scores):
    rng = np.random.default_rng(11)
    partner = np.where(rng.random((13, 17)) < 0.3, rng.integers(0, 17, (13, 17)), -1)
    partner[4] = -1  # a row without pairs
    ser = rng.random((13, 17)).astype(np.float32)
    vs = rng.random((13, 17)).astype(np.float32)
    flags = rng.integers(0, 4, (13, 17)).astype(np.uint8)
    want_flags = np.where(partner >= 0, flags | FLAG_FEATURE, flags)
    rows, cols = np.nonzero(partner >= 0)  # row-major, as the kernel
    empty = np.empty((0, 0), dtype=np.float32)
    got = divide.collect_features(
        partner, ser if with_scores else empty, vs if with_scores else empty, FLAG_FEATURE, flags
    )
    assert got.shape == (rows.size, 5)
    np.testing.assert_array_equal(got[:, 0], rows)
    np.testing.assert_array_equal(got[:, 1], cols)
    np.testing.assert_array_equal(got[:, 2], partner[rows, cols])
    if with_scores:
        np.testing.assert_array_equal(got[:, 3], ser[rows, cols])
        np.testing.assert_array_equal(got[:, 4], vs[rows, cols])
    else:
        assert np.isnan(got[:, 3:]).all()
    np.testing.assert_array_equal(flags, want_flags)


def test_collect_pairs_equals_collect_features():
    # the same pairs, stored per row (the band kernel's dc output) and per pixel
    rng = np.random.default_rng(12)
    height, width = 9, 23
    partner = np.full((height, width), -1, dtype=np.int64)
    ser = np.full((height, width), np.nan, dtype=np.float32)
    vs = np.full((height, width), np.nan, dtype=np.float32)
    pairs = np.full((height, width, 4), np.nan, dtype=np.float32)  # the rest is scratch
    counts = np.zeros(height, dtype=np.int64)
    for y in range(height):
        if y == 3:
            continue  # a row without pairs
        xs = np.sort(rng.choice(width, size=rng.integers(1, width), replace=False))
        for i, x in enumerate(xs):
            j, s, v = rng.integers(0, width), rng.random() * 50, rng.random()
            partner[y, x], ser[y, x], vs[y, x] = j, s, v
            pairs[y, i] = (x, j, ser[y, x], vs[y, x])
        counts[y] = xs.size
    flags = rng.integers(0, 4, (height, width)).astype(np.uint8)
    want_flags = flags.copy()
    want = divide.collect_features(partner, ser, vs, FLAG_FEATURE, want_flags)
    got = divide.collect_pairs(pairs, counts, FLAG_FEATURE, flags)
    assert got.dtype == want.dtype and got.shape == want.shape
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(flags, want_flags)
