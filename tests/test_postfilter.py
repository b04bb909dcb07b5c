"""The median post-filter (``dcstereo.refine.postfilter``): the kernel against a plain twin, what
it leaves alone, inside ``match`` and tiled, its errors, and ``run --median``."""

from dataclasses import replace

import numpy as np
import pytest

from dcstereo import FLAG_FEATURE, FLAG_FILLED, FLAG_OCCLUDED, MatchParams, io, match
from dcstereo.batch.tiling import match_tiled
from dcstereo.refine import _median as median_kernels
from dcstereo.refine import _postfilter as postfilter
from dcstereo.refine.postfilter import MAX_BINS, MAX_MEDIAN, median_filter, right_image_bounds
from test_cli import invoke


def twin(disparity, flags, size, params):
    """The filter as its docstring says, pixel by pixel: sorted values, the middle one(s)."""
    radius = size // 2
    height, width = disparity.shape
    out = disparity.copy()
    for y, x in np.ndindex(disparity.shape):
        if not np.isfinite(disparity[y, x]) or flags[y, x] & FLAG_FEATURE:
            continue
        window = disparity[max(0, y - radius) : y + radius + 1, max(0, x - radius) : x + radius + 1]
        values = sorted(float(v) for v in window.ravel() if np.isfinite(v))
        n = len(values)
        middle = values[n // 2] if n % 2 else (values[n // 2 - 1] + values[n // 2]) / 2
        middle = np.float32(middle)
        low = max(x - (width - 0.5), params.min_disparity)  # the disparities it can have
        high = min(x + 0.5, params.max_disparity)
        own = not flags[y, x] & FLAG_FILLED  # an estimate's median that moved stays among them
        if middle != disparity[y, x] and low <= high and own:
            middle = min(max(middle, np.float32(low)), np.float32(high))
        out[y, x] = np.float32(middle)
    return out


def random_result(seed, height=13, width=29, subpixel=True, low=0, values=9):
    """A dsi3 result whose map is replaced by every kind of pixel the filter meets.

    Without ``subpixel`` the map holds whole and half pixels only (from ``low``), the maps
    the matchers give, which the filter slides a histogram over.
    """
    rng = np.random.default_rng(seed)
    left = rng.integers(0, 256, (height, width), dtype=np.uint8)
    result = match(left, np.roll(left, -2, axis=1), max_disparity=4, window=3, method="dsi3")
    d = rng.integers(low, low + values, (height, width)).astype(np.float32)
    d[rng.random(d.shape) < 0.2] += 0.5  # half pixels
    if subpixel:
        d[rng.random(d.shape) < 0.1] += np.float32(rng.random())  # sub-pixel values
    d[rng.random(d.shape) < 0.25] = np.nan  # no estimate: an even count happens
    flags = np.where(np.isnan(d), FLAG_OCCLUDED, 0).astype(np.uint8)
    flags[(rng.random(d.shape) < 0.1) & ~np.isnan(d)] |= FLAG_FEATURE
    flags[(rng.random(d.shape) < 0.1) & ~np.isnan(d) & (flags == 0)] |= FLAG_FILLED
    params = replace(result.params, min_disparity=low, max_disparity=low + values)
    return replace(result, disparity=d, flags=flags, params=params)


@pytest.mark.parametrize("size", [3, 5, 7, MAX_MEDIAN])
@pytest.mark.parametrize("seed", [0, 1])
def test_kernel_equals_its_twin(size, seed):
    result = random_result(seed)
    filtered = median_filter(result, size)
    np.testing.assert_array_equal(
        filtered.disparity, twin(result.disparity, result.flags, size, result.params)
    )
    assert (filtered.disparity != result.disparity)[np.isfinite(result.disparity)].sum() > 20


@pytest.mark.parametrize("subpixel", [False, True])
@pytest.mark.parametrize("size", [3, 5, 9, MAX_MEDIAN])
@pytest.mark.parametrize("seed, low, values", [(0, 0, 9), (1, -7, 3), (2, 40, 64), (3, 5, 1)])
def test_the_sliding_histogram_equals_the_twin(subpixel, size, seed, low, values):
    result = random_result(seed, 17, 37, subpixel=subpixel, low=low, values=values)
    bins = np.empty(result.disparity.shape, dtype=np.int32)
    _, nbins, exact = postfilter.value_buckets(result.disparity, MAX_BINS, bins)
    assert nbins > 0 and exact == (not subpixel)  # the histogram's path, both of its modes
    filtered = median_filter(result, size)
    np.testing.assert_array_equal(
        filtered.disparity, twin(result.disparity, result.flags, size, result.params)
    )


@pytest.mark.parametrize("size", [3, 5, 7])
def test_the_network_of_full_windows_equals_the_twin_across_signs(size):
    # every window full (the network's path), values of both signs, both zeros and
    # magnitudes far apart: the int32 keys order them as the floats
    rng = np.random.default_rng(size)
    result = random_result(size, 14, 41, low=-9, values=18)
    d = rng.choice(np.array([-3e5, -7.25, -1.5, -1e-30, -0.0, 0.0, 1e-30, 0.5, 2.75, 4e5],
                            dtype=np.float32), (14, 41))  # fmt: skip
    d += np.where(rng.random(d.shape) < 0.3, rng.random(d.shape), 0).astype(np.float32)
    flags = np.zeros(d.shape, np.uint8)
    dense = replace(result, disparity=d, flags=flags)
    filtered = median_filter(dense, size).disparity
    np.testing.assert_array_equal(filtered, twin(d, flags, size, dense.params))


@pytest.mark.parametrize("size", [3, 5])
def test_the_network_equals_the_twin_across_chunks(size):
    # rows wider than two of the network's chunks: each chunk's windows read the columns
    # past its own, the last chunk is short
    rng = np.random.default_rng(10 + size)
    width = 2 * median_kernels.CHUNK + 13
    result = random_result(size, 9, width, low=0, values=30)
    d = (rng.integers(0, 30, (9, width)) + rng.random((9, width))).astype(np.float32)
    flags = np.zeros(d.shape, np.uint8)
    dense = replace(result, disparity=d, flags=flags)
    filtered = median_filter(dense, size).disparity
    np.testing.assert_array_equal(filtered, twin(d, flags, size, dense.params))
    assert (filtered != d).sum() > width


def test_sortable32_orders_float_bits_and_undoes_itself():
    values = np.array([-np.inf, -3e9, -2.5, -1e-30, -0.0, 0.0, 1e-30, 0.25, 7.0, 3e9, np.inf],
                      dtype=np.float32)  # fmt: skip
    bits = values.view(np.int32)
    keys = [int(median_kernels.sortable32(b)) for b in bits]
    assert keys == sorted(keys) and len(set(keys)) == len(keys)  # -0.0 just below +0.0
    assert keys[4] == -1 and keys[5] == 0  # by hand: 0x80000000 ^ 0x7FFFFFFF
    assert [int(median_kernels.sortable32(np.int32(k))) for k in keys] == bits.tolist()


def test_buckets_are_ordered_and_as_fine_as_the_span_allows():
    result = random_result(6, 15, 31)
    d = result.disparity
    bins = np.empty(d.shape, dtype=np.int32)
    for span, scale in ((20, postfilter.FINEST_BUCKETS), (1000, 16.0), (5000, 2.0)):
        wide = d.copy()
        wide[0, 0] = float(np.nanmin(d)) + span  # the map's span
        low, nbins, exact = postfilter.value_buckets(wide, MAX_BINS, bins)
        assert not exact and nbins == int(np.floor(scale * span)) + 1 and low == np.nanmin(d)
        finite = np.isfinite(wide)
        np.testing.assert_array_equal(bins[~finite], -1)
        order = np.argsort(wide[finite], kind="stable")
        assert np.all(np.diff(bins[finite][order]) >= 0)  # a larger value, never a lower one
        np.testing.assert_array_equal(
            median_filter(replace(result, disparity=wide), 5).disparity,
            twin(wide, result.flags, 5, result.params),
        )


def test_maps_the_histogram_does_not_take_are_sorted():
    result = random_result(4)
    d = result.disparity.copy()
    d[3, 3] = 9000.0  # a span of more than MAX_BINS half pixels
    wide = replace(result, disparity=d)
    bins = np.empty(d.shape, dtype=np.int32)
    assert postfilter.value_buckets(d, MAX_BINS, bins) == (0.0, 0, False)
    np.testing.assert_array_equal(
        median_filter(wide, 5).disparity, twin(d, result.flags, 5, result.params)
    )
    empty = replace(result, disparity=np.full_like(d, np.nan))
    assert postfilter.value_buckets(empty.disparity, MAX_BINS, bins)[1] == 0
    assert np.isnan(median_filter(empty, 3).disparity).all()
    # the sort and the histogram agree, on maps of half pixels and sub-pixel maps
    for subpixel in (False, True):
        result = random_result(5, subpixel=subpixel)
        d = result.disparity
        low, nbins, exact = postfilter.value_buckets(d, MAX_BINS, bins)
        moved = np.isfinite(d)
        a, b = d.copy(), d.copy()
        postfilter.median_rows(d, moved, 2, a)
        postfilter.median_rows_binned(d, bins, moved, 2, nbins, low, exact, b)
        np.testing.assert_array_equal(a, b)


def test_what_is_left_alone():
    result = random_result(3)
    filtered = median_filter(result, 5)
    d = result.disparity
    assert np.array_equal(np.isnan(filtered.disparity), np.isnan(d))  # occlusions stay
    feature = (result.flags & FLAG_FEATURE) != 0
    np.testing.assert_array_equal(filtered.disparity[feature], d[feature])
    assert filtered.flags is result.flags and filtered.params == result.params
    assert filtered.features is result.features


def test_a_spike_and_a_streak_go():
    d = np.full((9, 20), 6.0, dtype=np.float32)
    d[4, 7] = 13.0  # a spike
    d[2, 8:15] = 2.0  # a one-row streak, as a scanline DP leaves
    d[:, :6] = np.nan  # (left of column 6 a disparity of 6 points outside the right image)
    result = replace(random_result(0, 9, 20), disparity=d, flags=np.zeros(d.shape, np.uint8))
    out = median_filter(result, 3).disparity
    np.testing.assert_array_equal(out[:, 6:], 6.0)
    assert np.isnan(out[:, :6]).all()


def test_a_median_points_inside_the_right_image():
    d = np.minimum(np.arange(12, dtype=np.float32), 4.0)[None].repeat(5, axis=0)
    result = replace(random_result(0, 5, 12), disparity=d, flags=np.zeros(d.shape, np.uint8))
    result = replace(result, params=replace(result.params, max_disparity=11))
    out = median_filter(result, 5).disparity
    # column 0's median, 1, points left of the right image: it is limited to 0.5 (the left
    # edge of the first pixel); column 1's, 1.5, points at that edge and stays
    np.testing.assert_array_equal(out[:, 0], 0.5)
    np.testing.assert_array_equal(out[:, 1], 1.5)
    np.testing.assert_array_equal(out[:, 2:], d[:, 2:])
    # a filled pixel has no match in the right image: it keeps its median
    filled = np.zeros(d.shape, np.uint8)
    filled[:, 0] = FLAG_FILLED
    out = median_filter(replace(result, flags=filled), 5).disparity
    np.testing.assert_array_equal(out[:, 0], 1.0)
    # without column 0, column 1's median is 2.5 (of 1, 2, 3 and 4): limited to 1.5
    holed = d.copy()
    holed[:, 0] = np.nan
    out = median_filter(replace(result, disparity=holed), 5).disparity
    np.testing.assert_array_equal(out[:, 1], 1.5)


def _naive_inside(out, d, filled, bottom, top):
    """The twin of ``limit_inside``: the rule as numpy arrays (the bounds ``planes`` uses)."""
    least, largest = right_image_bounds(out.shape[1])
    low = np.where(filled, bottom, np.maximum(least, bottom))
    high = np.where(filled, top, np.minimum(largest, top))
    limit = (out != d) & (low <= high)
    return np.where(limit, np.clip(out, low, high), out)


def test_limit_inside_equals_twin():
    rng = np.random.default_rng(8)
    for _ in range(200):
        height, width = (int(v) for v in rng.integers(1, 12, 2))
        bottom, top = sorted(rng.integers(-6, 10, 2))
        d = rng.uniform(bottom - 3, top + 3, (height, width)).astype(np.float32)
        d[rng.random(d.shape) < 0.2] = np.nan
        out = np.where(rng.random(d.shape) < 0.5, d, d + rng.normal(0, 3, d.shape)).astype(
            np.float32
        )
        out[rng.random(d.shape) < 0.1] = np.nan
        filled = rng.random(d.shape) < 0.3
        want = _naive_inside(out, d, filled, np.float32(bottom), np.float32(top))
        bounds = right_image_bounds(width)
        postfilter.limit_inside(out, d, filled, *bounds, np.float32(bottom), np.float32(top))
        np.testing.assert_array_equal(out, want)


def test_limit_inside_by_hand():
    # width 3, range 0..5: column 0 allows 0..0.5, column 2 allows 0..2.5 (filled: 0..5)
    d = np.zeros((1, 3), np.float32)
    out = np.array([[4.0, 0.0, 4.0]], np.float32)  # column 1 unchanged: left as it is
    bounds = right_image_bounds(3)
    filled = np.array([[False, False, True]])
    postfilter.limit_inside(out, d, filled, *bounds, np.float32(0), np.float32(5))
    assert out.tolist() == [[0.5, 0.0, 4.0]]
    out = np.array([[-1.0, np.nan, 9.0]], np.float32)
    postfilter.limit_inside(out, d, np.zeros((1, 3), bool), *bounds, np.float32(0), np.float32(5))
    assert out[0, 0] == 0.0 and np.isnan(out[0, 1]) and out[0, 2] == 2.5


def test_match_filters_after_subpixel_and_before_filling(pair):
    folder, _ = pair
    left, right = io.read_image(folder / "left.png"), io.read_image(folder / "right.png")
    dc = {"max_disparity": 10, "method": "dc"}
    plain = match(left, right, subpixel="parabola", **dc)
    inside = match(left, right, subpixel="parabola", median=5, **dc)
    np.testing.assert_array_equal(inside.disparity, median_filter(plain, 5).disparity)
    assert inside.params.median == 5 and plain.params.median == 0
    filled = match(left, right, subpixel="parabola", median=5, fill=True, **dc)
    np.testing.assert_array_equal(filled.disparity, median_filter(plain, 5).filled().disparity)
    # the reliable pairs keep their disparities: the path still passes through them
    whole = match(left, right, median=5, **dc)
    rows, xl, xr = (whole.features[:, i].astype(int) for i in range(3))
    assert len(rows) > 20
    np.testing.assert_array_equal(whole.disparity[rows, xl], xl - xr)


@pytest.mark.parametrize("fill", [False, True])
def test_tiled_equals_untiled(pair, fill):
    folder, _ = pair
    left, right = io.read_image(folder / "left.png"), io.read_image(folder / "right.png")
    kwargs = {"max_disparity": 10, "median": 5, "fill": fill}
    whole = match(left, right, **kwargs)
    tiled = match_tiled(left, right, tile_rows=4, **kwargs)
    np.testing.assert_array_equal(tiled.disparity, whole.disparity)
    np.testing.assert_array_equal(tiled.flags, whole.flags)
    np.testing.assert_array_equal(tiled.features, whole.features)
    assert tiled.params == whole.params


def test_errors():
    result = random_result(0)
    for bad in (1, 2, 4, MAX_MEDIAN + 2, -3):
        message = f"median must be 0 \\(off\\) or an odd integer from 3 to {MAX_MEDIAN}, got {bad}"
        with pytest.raises(ValueError, match=message):
            MatchParams(max_disparity=4, median=bad)
    for bad in (True, 2.5, "5"):  # None: the method's default
        with pytest.raises(TypeError, match="median must be an integer"):
            MatchParams(max_disparity=4, median=bad)
    assert MatchParams(max_disparity=4, median=np.int64(3)).median == 3
    with pytest.raises(ValueError, match="size must be an odd integer from 3, got 0"):
        median_filter(result, 0)
    with pytest.raises(ValueError, match="size must be 0 \\(off\\) or an odd integer"):
        median_filter(result, 4)
    with pytest.raises(TypeError, match="result must be a DisparityResult, got ndarray"):
        median_filter(result.disparity, 3)


def test_run_median(pair):
    folder, _ = pair
    left, right = io.read_image(folder / "left.png"), io.read_image(folder / "right.png")
    out = folder / "d.pfm"
    result = invoke("run", folder / "left.png", folder / "right.png", "-o", out,
                    "--max-disparity", 10, "--median", 3, "--fill", "-q")  # fmt: skip
    assert result.exit_code == 0, result.output
    expected = match(left, right, max_disparity=10, median=3, fill=True)
    np.testing.assert_array_equal(io.read_pfm(out), expected.disparity)
    bad = folder / "bad.pfm"
    result = invoke("run", folder / "left.png", folder / "right.png", "-o", bad,
                    "--max-disparity", 10, "--median", 4)  # fmt: skip
    lines = result.output.strip().splitlines()
    assert result.exit_code == 1 and len(lines) == 1 and "median must be 0 (off)" in lines[0]
    assert not bad.exists()
