"""``dcstereo.match`` end to end: hand cases, synthetic stereograms, invariances, bad input."""

import numba
import numpy as np
import pytest

import dcstereo
import synthetic
from dcstereo import FLAG_BORDER, FLAG_FILLED, FLAG_OCCLUDED
from dcstereo.methods import _bands as mbands

DP_METHODS = ["dsi3", "dsi5"]
ALL_METHODS = ["block", "dsi3", "dsi5"]


def scanline(values):
    return np.array([values], dtype=np.uint8)


# --------------------------------------------------------------------------- hand cases


@pytest.mark.parametrize("method", DP_METHODS)
def test_hand_1x7_occlusion(method):
    # Right: 10 50 200 120 30 170 90. Left pixels 0, 1 see the same background (d = 0);
    # left pixel 2 (250) is seen by the left camera only; left 3..6 are right 2..5 (d = 1).
    # With a 1-pixel window the optimum is c c a c c c c at cost C_occ = 20, every
    # alternative costs at least |50 - 10| + |250 - 50| = 240 (start at d = 1) or 50.
    right = scanline([10, 50, 200, 120, 30, 170, 90])
    left = scanline([10, 50, 250, 200, 120, 30, 170])
    result = dcstereo.match(
        left, right, max_disparity=1, method=method, window=1, occlusion_cost=20
    )
    np.testing.assert_array_equal(result.disparity[0], [0, 0, np.nan, 1, 1, 1, 1])
    np.testing.assert_array_equal(result.flags[0], [0, 0, FLAG_OCCLUDED, 0, 0, 0, 0])
    assert result.path_cost[0] == 20.0
    np.testing.assert_array_equal(
        result.pairs(), [[0, 0, 0], [0, 1, 1], [0, 3, 2], [0, 4, 3], [0, 5, 4], [0, 6, 5]]
    )


def test_hand_1x7_half_pixel_e_step():
    # Left pixel 2 (50) lies between right pixels 1 and 2 (both 50): the e step from
    # (1, 1) to (3, 2) costs DSI(3,2) + (DSI(2,2) + DSI(2,1)) / 2 = 0, so dsi5 explains the
    # row at cost 0 with disparity 0.5 at x = 2; dsi3 must pay one occlusion (C_occ = 20).
    right = scanline([10, 50, 50, 120, 30, 170, 90])
    left = scanline([10, 50, 50, 50, 120, 30, 170])
    five = dcstereo.match(left, right, max_disparity=1, method="dsi5", window=1, occlusion_cost=20)
    np.testing.assert_array_equal(five.disparity[0], [0, 0, 0.5, 1, 1, 1, 1])
    assert five.path_cost[0] == 0.0
    assert not five.occluded.any()
    three = dcstereo.match(left, right, max_disparity=1, method="dsi3", window=1, occlusion_cost=20)
    assert three.path_cost[0] == 20.0
    assert np.count_nonzero(three.flags[0] == FLAG_OCCLUDED) == 1
    # the half-pixel value is not an integer pair
    assert [0, 2, 1] not in five.pairs().tolist()


def test_border_pixels_have_no_partner():
    rng = np.random.default_rng(11)
    left, right = synthetic.constant_pair(rng, 8, 30, 4)
    result = dcstereo.match(left, right, max_disparity=6, method="dsi5", window=3)
    # left pixels x < 4 see scene the right camera does not: border (or occluded), no value
    assert np.isnan(result.disparity[:, :4]).all()
    assert (result.flags[:, :4] & (FLAG_BORDER | FLAG_OCCLUDED)).all()
    assert result.occluded[:, :4].all()


# --------------------------------------------------------------------------- synthetic


@pytest.mark.parametrize("method", ALL_METHODS)
@pytest.mark.parametrize("disparity", [0, 3, 9])
def test_constant_disparity_is_exact(method, disparity):
    rng = np.random.default_rng(21)
    left, right = synthetic.constant_pair(rng, 24, 64, disparity)
    result = dcstereo.match(left, right, max_disparity=12, method=method)
    np.testing.assert_array_equal(result.disparity[:, disparity + 2 :], disparity)


@pytest.mark.parametrize("method", DP_METHODS)
def test_foreground_object_occlusion_band(method):
    rng = np.random.default_rng(31)
    x0, x1, back, front = 30, 60, 2, 10
    left, right, truth = synthetic.object_pair(rng, 30, 96, back, front, (x0, x1))
    # At C_occ = 20 the band is exact to a pixel; at the default 10 the DP also gives up
    # one or two pixels on each side of it, where the 5x5 windows straddle the edges.
    result = dcstereo.match(
        left, right, max_disparity=14, method=method, window=5, occlusion_cost=20
    )
    band = slice(x0 - (front - back), x0)  # the 8 background pixels hidden in the right view
    occluded = result.occluded
    # the band is found (allowing one pixel at each edge to go either way with a 5x5 window)
    inner = slice(band.start + 1, band.stop - 1)
    assert occluded[:, inner].mean() >= 0.95
    # and nothing else is occluded away from the band and the left border
    away = np.ones(truth.shape[1], dtype=bool)
    away[: back + 1] = False
    away[band.start - 1 : band.stop + 1] = False
    assert occluded[:, away].mean() <= 0.01
    # the band is as wide as the disparity jump on most rows
    widths = occluded[:, band.start - 3 : band.stop + 3].sum(axis=1)
    assert np.median(widths) == front - back
    # disparities away from the discontinuity are exact
    scored = np.isfinite(truth)
    scored[:, x0 - 10 : x0 + 3] = False
    scored[:, x1 - 3 : x1 + 3] = False
    np.testing.assert_array_equal(result.disparity[scored], truth[scored])


def slanted_errors(method, slope, occlusion_cost):
    rng = np.random.default_rng(5)
    left, right, truth = synthetic.slanted_pair(rng, 40, 120, 4, slope)
    scored = np.isfinite(truth)
    result = dcstereo.match(
        left,
        right,
        max_disparity=int(np.nanmax(truth)) + 4,
        method=method,
        occlusion_cost=occlusion_cost,
    )
    false_occlusions = (result.flags & FLAG_OCCLUDED).astype(bool)[scored].mean()
    error = np.abs(result.filled().disparity - truth)[scored]
    return false_occlusions, error.mean(), (error > 1).mean()


def test_dsi5_follows_a_slanted_plane_where_dsi3_breaks_it_into_occlusions():
    # Measured on this pair (slope 0.25, default C_occ = 20): dsi3 marks 24 % of the plane
    # occluded (one a step per disparity increment), dsi5 1.3 %; MAE 0.26 vs 0.14 pixel.
    occ3, mae3, bad3 = slanted_errors("dsi3", 0.25, 20.0)
    occ5, mae5, bad5 = slanted_errors("dsi5", 0.25, 20.0)
    assert occ3 >= 0.15
    assert occ5 <= 0.2 * occ3
    assert mae5 <= 0.7 * mae3
    assert bad5 <= 0.01


def test_dsi5_survives_a_steep_slant_at_a_high_occlusion_cost():
    # Measured: slope 0.4, C_occ = 40: dsi3 bad-1 55 %, dsi5 0.9 %.
    _, _, bad3 = slanted_errors("dsi3", 0.4, 40.0)
    _, _, bad5 = slanted_errors("dsi5", 0.4, 40.0)
    assert bad3 >= 0.3
    assert bad5 <= 0.03


# --------------------------------------------------------------------------- invariances


@pytest.mark.parametrize("method", ALL_METHODS)
def test_identity_gives_zero_everywhere(method):
    rng = np.random.default_rng(41)
    image = synthetic.texture(rng, 20, 50)
    result = dcstereo.match(image, image, max_disparity=8, method=method)
    np.testing.assert_array_equal(result.disparity, 0)
    assert not result.occluded.any()


def test_mirrored_pair_gives_the_mirrored_matches():
    # Swapping the views and flipping both left-right maps the pair (x_l, x_r) to
    # (W-1-x_r, W-1-x_l). dsi3's model is symmetric under that map (edge padding and
    # the free ends included), so with a unique optimum the matches agree exactly.
    rng = np.random.default_rng(51)
    left, right, _ = synthetic.object_pair(rng, 16, 80, 2, 9, (30, 55))
    width = left.shape[1]
    forward = dcstereo.match(left, right, max_disparity=12, method="dsi3")
    mirrored = dcstereo.match(right[:, ::-1], left[:, ::-1], max_disparity=12, method="dsi3")
    np.testing.assert_allclose(forward.path_cost, mirrored.path_cost)
    pairs = {tuple(p) for p in forward.pairs().tolist()}
    back = {(r, width - 1 - xr, width - 1 - xl) for r, xl, xr in mirrored.pairs().tolist()}
    assert pairs == back


def test_mirrored_pair_dsi5_agrees_on_almost_every_match():
    # dsi5 charges the target cell of a d/e step in full, so reversing the scan changes
    # which cell pays: the maps agree up to a few pixels at discontinuities.
    rng = np.random.default_rng(52)
    left, right, _ = synthetic.object_pair(rng, 16, 80, 2, 9, (30, 55))
    width = left.shape[1]
    forward = dcstereo.match(left, right, max_disparity=12, method="dsi5")
    mirrored = dcstereo.match(right[:, ::-1], left[:, ::-1], max_disparity=12, method="dsi5")
    pairs = {tuple(p) for p in forward.pairs().tolist()}
    back = {(r, width - 1 - xr, width - 1 - xl) for r, xl, xr in mirrored.pairs().tolist()}
    assert len(pairs & back) >= 0.98 * len(pairs)


@pytest.mark.parametrize("method", ALL_METHODS)
def test_dtype_invariance(method):
    rng = np.random.default_rng(61)
    left, right, _ = synthetic.object_pair(rng, 12, 48, 1, 6, (20, 34))
    reference = dcstereo.match(left, right, max_disparity=8, method=method)
    variants = [
        (left.astype(np.uint16) * 257, right.astype(np.uint16) * 257),
        (left / 255.0, right / 255.0),
        (left.astype(np.float32) / 255, right.astype(np.float32) / 255),
        (np.repeat(left[:, :, None], 3, axis=2), np.repeat(right[:, :, None], 3, axis=2)),
    ]
    for a, b in variants:
        result = dcstereo.match(a, b, max_disparity=8, method=method)
        np.testing.assert_array_equal(result.disparity, reference.disparity)
        np.testing.assert_array_equal(result.flags, reference.flags)


def test_min_disparity_shifts_the_search():
    rng = np.random.default_rng(71)
    left, right = synthetic.constant_pair(rng, 12, 50, 7)
    result = dcstereo.match(left, right, min_disparity=5, max_disparity=9, method="dsi5")
    np.testing.assert_array_equal(result.disparity[:, 9:], 7)
    # a range that excludes the truth cannot find it
    wrong = dcstereo.match(left, right, min_disparity=0, max_disparity=4, method="block")
    assert not (wrong.disparity == 7).any()


def test_negative_disparities():
    rng = np.random.default_rng(72)
    right, left = synthetic.constant_pair(rng, 12, 50, 3)  # swapped: left x -> right x + 3
    result = dcstereo.match(left, right, min_disparity=-5, max_disparity=0, method="dsi5")
    np.testing.assert_array_equal(result.disparity[:, : 50 - 5], -3)


def test_fill_gives_a_dense_map_with_background_values():
    rng = np.random.default_rng(81)
    left, right, truth = synthetic.object_pair(rng, 20, 80, 2, 10, (30, 55))
    sparse = dcstereo.match(left, right, max_disparity=12, method="dsi5")
    dense = dcstereo.match(left, right, max_disparity=12, method="dsi5", fill=True)
    assert np.isfinite(dense.disparity).all()
    holes = ~np.isfinite(sparse.disparity)
    assert (dense.flags[holes] & FLAG_FILLED).all()
    assert not (dense.flags[~holes] & FLAG_FILLED).any()
    # the occluded band left of the object takes the background disparity
    np.testing.assert_array_equal(dense.disparity[:, 23:29], 2)


def test_band_chunks_one_for_a_lone_thread_four_a_thread_else():
    # the band kernels' chunks (their maps do not depend on them: test_band_kernels)
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        assert mbands._band_chunks(375) == 1
        if numba.config.NUMBA_NUM_THREADS >= 2:
            numba.set_num_threads(2)
            assert mbands._band_chunks(375) == 8
            assert mbands._band_chunks(17) == 3  # no more chunks than bands
    finally:
        numba.set_num_threads(before)


def test_result_carries_its_parameters():
    rng = np.random.default_rng(82)
    left, right = synthetic.constant_pair(rng, 10, 30, 2)
    result = dcstereo.match(left, right, max_disparity=4, method="dsi3", occlusion_cost=7)
    assert result.method == "dsi3"
    assert result.params.occlusion_cost == 7
    assert result.disparity.dtype == np.float32 and result.flags.dtype == np.uint8
    assert result.path_cost.shape == (10,)


# --------------------------------------------------------------------------- bad input


def good_pair():
    rng = np.random.default_rng(91)
    return synthetic.constant_pair(rng, 10, 20, 2)


@pytest.mark.parametrize(
    ("change", "error", "message"),
    [
        (lambda a, b: (a, b[:, :-1]), ValueError, r"differ in shape: \(10, 20\) vs \(10, 19\)"),
        (lambda a, b: (a[:0], b[:0]), ValueError, "empty"),
        (lambda a, b: (a / 255.0, np.where(b > 9, np.nan, b / 255.0)), ValueError, "NaN"),
        (lambda a, b: (a * 1.0, b * 1.0), ValueError, r"must lie in \[0, 1\]"),
        (lambda a, b: (a.astype(np.int32), b.astype(np.int32)), TypeError, "dtype int32"),
        (lambda a, b: (a > 3, b > 3), TypeError, "dtype bool"),
        (lambda a, b: (a[0], b[0]), ValueError, "expected \\(H, W\\)"),
        (lambda a, b: (a[..., None, None], b[..., None, None]), ValueError, "shape"),
    ],
)
def test_bad_images(change, error, message):
    left, right = change(*good_pair())
    with pytest.raises(error, match=message):
        dcstereo.match(left, right, max_disparity=4)


@pytest.mark.parametrize(
    ("options", "error", "message"),
    [
        ({"max_disparity": 20}, ValueError, "does not fit an image 20 pixels wide"),
        ({"max_disparity": 2, "min_disparity": -20}, ValueError, "min_disparity=-20"),
        ({"max_disparity": 2, "min_disparity": 3}, ValueError, "larger than max_disparity"),
        ({"max_disparity": 4, "window": 11}, ValueError, "window=11 is larger than the image"),
        ({"max_disparity": 4, "window": 4}, ValueError, "positive odd"),
        ({"max_disparity": 4, "window": 727}, ValueError, "larger than 725"),
        ({"max_disparity": 4, "window": 515, "cost": "bt", "method": "dc"}, ValueError, "513"),
        ({"max_disparity": 4, "method": "sgbm"}, ValueError, "unknown method 'sgbm'"),
        ({"max_disparity": 4, "cost": "sad"}, ValueError, "cost='sad' is not supported by sgm"),
        ({"max_disparity": 4, "paths": 6}, ValueError, "paths must be 4 or 8"),
        ({"max_disparity": 4, "census_window": (4, 5)}, ValueError, "census_window must"),
        ({"max_disparity": 4, "census_window": (9, 9)}, ValueError, "gives 80 bits"),
        ({"max_disparity": 4, "p1": 50, "p2": 40}, ValueError, r"p2 \(40\) must be at least"),
        ({"max_disparity": 4, "occlusion_cost": 0}, ValueError, "occlusion_cost must be"),
        ({"max_disparity": 4, "occlusion_cost": float("nan")}, ValueError, "finite"),
        ({"max_disparity": 4.5}, TypeError, "max_disparity must be an integer"),
        ({"max_disparity": 4, "colour": True}, TypeError, "colour"),
    ],
)
def test_bad_parameters(options, error, message):
    left, right = good_pair()
    with pytest.raises(error, match=message):
        dcstereo.match(left, right, **options)


def layouts(gray, rng, layout):
    """``gray`` (H, W) uint8 in ``layout``: gray, or an RGB/RGBA image with other channels."""
    if layout == "gray":
        return gray
    noise = rng.integers(-6, 7, gray.shape + (3,))
    colour = np.clip(gray[..., None].astype(int) + noise, 0, 255).astype(np.uint8)
    if layout == "rgba":
        colour = np.concatenate([colour, rng.integers(0, 256, gray.shape + (1,), np.uint8)], -1)
    return colour


@pytest.mark.parametrize(("left_layout", "right_layout"), [("gray", "rgb"), ("rgba", "gray")])
def test_gray_and_colour_pair_of_one_size_is_accepted(left_layout, right_layout):
    from dcstereo.batch.tiling import match_tiled
    from dcstereo.evaluation.scoring import available_methods, run_method
    from dcstereo.signal import intensity, matching_signal
    from dcstereo.viz.explore import dsi_row

    rng = np.random.default_rng(17)
    left, right, _ = synthetic.object_pair(rng, 30, 40, 2, 6, (12, 26))
    left, right = layouts(left, rng, left_layout), layouts(right, rng, right_layout)
    # the reference: each image turned to gray by the library's own conversion
    gray_left, gray_right = intensity(left) / 255.0, intensity(right) / 255.0
    for image, gray in ((left, gray_left), (right, gray_right)):
        np.testing.assert_array_equal(matching_signal(gray), matching_signal(image))
    for method in available_methods():
        if method == "sgm-accurate" and left_layout != "gray":
            # its weighted median, local planes and superpixels follow the left image's
            # colours, which the gray reference has not: the gray left case holds it
            continue
        mixed = run_method(method, left, right, max_disparity=8)
        plain = run_method(method, gray_left, gray_right, max_disparity=8)
        np.testing.assert_array_equal(mixed.disparity, plain.disparity, err_msg=method)
        np.testing.assert_array_equal(mixed.flags, plain.flags, err_msg=method)
    tiled = match_tiled(left, right, tile_rows=8, max_disparity=8, method="dsi5")
    plain = dcstereo.match(gray_left, gray_right, max_disparity=8, method="dsi5")
    np.testing.assert_array_equal(tiled.disparity, plain.disparity)
    np.testing.assert_array_equal(
        dsi_row(left, right, 7, max_disparity=8), dsi_row(gray_left, gray_right, 7, max_disparity=8)
    )


def test_gray_and_colour_pair_of_other_sizes_differ_in_shape():
    left, right = good_pair()
    colour = np.stack([right[:, :-1]] * 3, axis=-1)
    with pytest.raises(ValueError, match=r"differ in shape: \(10, 20\) vs \(10, 19, 3\)"):
        dcstereo.match(left, colour, max_disparity=4)
