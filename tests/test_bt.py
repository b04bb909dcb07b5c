"""The Birchfield-Tomasi cost: hand-computed cells, the naive twin, every method with it."""

import numpy as np
import pytest

import dcstereo
import naive_gcp_bt
import synthetic
from dcstereo.costs import window as costs
from dcstereo.evaluation.scoring import parse_methods, run_method

BT_METHODS = ["block", "dsi3", "dsi5", "dc", "dc-linear", "dsi3-gcp"]


def kernel_costs(left, right, dmin, ndisp, radius, incremental=True):
    """``row_costs_bt`` over every row of an unpadded int32 pair (rows in order)."""
    height, width = left.shape
    pad = ((radius, radius), (radius, radius))
    left_p, right_p = np.pad(left, pad, mode="edge"), np.pad(right, pad, mode="edge")
    out = np.empty((width, ndisp))
    vcol = np.empty((width, ndisp), dtype=np.int32)
    rows = []
    for y in range(height):
        costs.row_costs_bt(
            left_p, right_p, y, dmin, ndisp, radius, vcol, out, incremental and y > 0
        )
        rows.append(out.copy())
    return rows


def test_bt_of_a_1x5_row_by_hand():
    # L = [0, 4, 8, 0, 6], R = [2, 6, 2, 8, 8], window 1 (radius 0), d = 0 and 1.
    # d = 0, x = 0: R around 0 is {2 (edge: itself), 2, 4} -> d_LR = 2 - 0 = 2;
    #   L around 0 is {0, 0, 2} holds R = 2 -> d_RL = 0; BT = 0 (SAD 2)
    # x = 1: R around 1 is {4, 6, 4} holds 4 -> 0 (SAD 2)
    # x = 2: R around 2 is {4, 2, 5}: 8 - 5 = 3; L around 2 is {6, 8, 4}: 4 - 2 = 2 -> 2
    # x = 3: R around 3 is {5, 8, 8}: 5 - 0 = 5; L around 3 is {4, 0, 3}: 8 - 4 = 4 -> 4
    # x = 4: R around 4 is {8, 8, 8 (edge)}: 2; L around 4 is {3, 6, 6}: 8 - 6 = 2 -> 2
    # d = 1, x = 1 <-> j = 0: R {2, 2, 4} holds 4 -> 0; x = 2 <-> 1: L {6, 8, 4} holds 6 -> 0
    # x = 3 <-> 2: L {4, 0, 3} holds 2 -> 0; x = 4 <-> 3: R {5, 8, 8} holds 6 -> 0
    left = np.array([[0, 4, 8, 0, 6]], dtype=np.int32)
    right = np.array([[2, 6, 2, 8, 8]], dtype=np.int32)
    (out,) = kernel_costs(left, right, 0, 2, 0)
    expected = np.array([[0, np.inf], [0, 0], [2, 0], [4, 0], [2, 0]], dtype=np.float64)
    np.testing.assert_array_equal(out, expected)
    np.testing.assert_array_equal(naive_gcp_bt.row_costs_bt(left, right, 0, 0, 2, 0), expected)


def test_bt_half_gray_level_from_the_interpolation():
    # x = 1 <-> j = 1: L = 5 against R {1, 2, 4.5} (halves of 0 + 2 and 2 + 7): 0.5 above;
    # R = 2 against L {5, 5, 5}: 3 below. BT = min(0.5, 3) = 0.5, SAD 3.
    left = np.array([[5, 5, 5]], dtype=np.int32)
    right = np.array([[0, 2, 7]], dtype=np.int32)
    (out,) = kernel_costs(left, right, 0, 1, 0)
    assert out[1, 0] == 0.5
    assert naive_gcp_bt.bt_pixel(left[0], right[0], 1, 1) == 0.5


@pytest.mark.parametrize("radius", [0, 1, 2])
@pytest.mark.parametrize("dmin", [-2, 0, 3])
def test_row_costs_bt_match_naive(radius, dmin):
    rng = np.random.default_rng(17 + radius)
    height, width, ndisp = 6, 11, 5
    left = rng.integers(0, 4096, size=(height, width)).astype(np.int32)
    right = rng.integers(0, 4096, size=(height, width)).astype(np.int32)
    incremental = kernel_costs(left, right, dmin, ndisp, radius, True)
    fresh = kernel_costs(left, right, dmin, ndisp, radius, False)
    for y in range(height):
        expected = naive_gcp_bt.row_costs_bt(left, right, y, dmin, ndisp, radius)
        np.testing.assert_array_equal(incremental[y], expected)
        np.testing.assert_array_equal(fresh[y], expected)


@pytest.mark.parametrize("dmin", [-12, -3, 4, 11])
def test_row_costs_bt_match_naive_when_the_band_leaves_the_image(dmin):
    rng = np.random.default_rng(23)
    height, width, ndisp, radius = 4, 9, 6, 2
    left = rng.integers(0, 4096, size=(height, width)).astype(np.int32)
    right = rng.integers(0, 4096, size=(height, width)).astype(np.int32)
    rows = kernel_costs(left, right, dmin, ndisp, radius)
    for y in range(height):
        expected = naive_gcp_bt.row_costs_bt(left, right, y, dmin, ndisp, radius)
        np.testing.assert_array_equal(rows[y], expected)


def test_bt_is_never_more_than_sad_and_zero_on_identity():
    rng = np.random.default_rng(29)
    image = rng.integers(0, 256, size=(8, 20), dtype=np.uint8)
    other = rng.integers(0, 256, size=(8, 20), dtype=np.uint8)
    signal = dcstereo.signal.matching_signal
    left, right = signal(image), signal(other)
    radius = 1
    pad = ((radius, radius), (radius, radius))
    left_p, right_p = np.pad(left, pad, mode="edge"), np.pad(right, pad, mode="edge")
    sad = np.empty((20, 4))
    bt = np.empty((20, 4))
    vcol = np.empty((20, 4), dtype=np.int32)
    for y in range(8):
        costs.row_costs(left_p, right_p, y, 0, 4, radius, vcol, sad, False)
        costs.row_costs_bt(left_p, right_p, y, 0, 4, radius, vcol, bt, False)
        finite = np.isfinite(sad)
        np.testing.assert_array_equal(finite, np.isfinite(bt))
        assert np.all(bt[finite] <= sad[finite])
    same = kernel_costs(left, left, 0, 1, radius)
    for out in same:
        np.testing.assert_array_equal(out, 0.0)


@pytest.mark.parametrize("method", BT_METHODS)
def test_every_dp_method_with_bt_recovers_a_constant_disparity(method):
    rng = np.random.default_rng(31)
    disparity = 4
    left, right = synthetic.constant_pair(rng, 24, 60, disparity)
    result = dcstereo.match(left, right, max_disparity=8, method=method, cost="bt")
    assert result.params.cost == "bt"
    # every pixel whose window has a partner in the right image
    inner = result.disparity[:, disparity + 2 : -2]
    np.testing.assert_array_equal(inner, disparity)


def test_bt_and_sad_differ_on_a_subpixel_shift():
    # a smooth texture shifted by 2.5 px: BT sees (nearly) no mismatch, SAD does
    rng = np.random.default_rng(37)
    wide = synthetic.texture(rng, 16, 130, smooth=4).astype(np.float64)
    left = np.rint(wide[:, 5:125]).astype(np.uint8)
    right = np.rint((wide[:, 7:127] + wide[:, 8:128]) / 2).astype(np.uint8)
    sad = dcstereo.match(left, right, max_disparity=6, method="dsi3")
    bt = dcstereo.match(left, right, max_disparity=6, method="dsi3", cost="bt")
    assert np.nanmean(bt.path_cost) < np.nanmean(sad.path_cost)


def test_bad_cost_is_a_value_error_naming_it():
    left = np.zeros((8, 16), dtype=np.uint8)
    with pytest.raises(ValueError, match="unknown cost 'ncc'"):
        dcstereo.match(left, left, max_disparity=2, cost="ncc")
    with pytest.raises(ValueError, match="cost='bt' is not supported by redert"):
        dcstereo.match(left, left, max_disparity=2, method="redert", cost="bt")


def test_bench_names_with_bt_suffix_run_with_the_bt_cost():
    assert parse_methods("dsi5+bt,dsi3") == ["dsi5+bt", "dsi3"]
    with pytest.raises(ValueError, match="unknown method"):
        parse_methods("redert+bt")
    rng = np.random.default_rng(41)
    left, right = synthetic.constant_pair(rng, 12, 40, 3)
    result = run_method("dsi5+bt", left, right, max_disparity=5)
    assert result.params.cost == "bt" and result.method == "dsi5"
