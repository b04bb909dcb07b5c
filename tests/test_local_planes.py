"""The local planes after the weighted median (``median="weighted-planes"``)."""

import numpy as np
import pytest

import dcstereo
import naive_local_planes as naive
from cli_runs import run_equals_match
from dcstereo.params import MatchParams
from dcstereo.refine import _local_planes as lp_kernels
from dcstereo.refine import local_planes as lp
from dcstereo.refine.weighted_median import weight_tables, weighted_median_filter
from dcstereo.result import FLAG_FEATURE, FLAG_FILLED, FLAG_OCCLUDED, DisparityResult
from pins import kitti_d1, middlebury_bad1


def _planes(d, guide, radius=lp.RADIUS, tolerance=lp.TOLERANCE, moved=None):
    guide = np.asarray(guide)
    guide = guide[None] if guide.ndim == 2 else guide
    moved = np.isfinite(d) if moved is None else moved
    return lp.local_planes(d, guide, moved, radius, tolerance, lp.COLOUR_SCALE, lp.SPACE_SCALE)


def _result(d, flags=None, max_disparity=40):
    params = MatchParams(max_disparity=max_disparity, method="sgm")
    flags = np.zeros(d.shape, np.uint8) if flags is None else flags
    return DisparityResult(d.astype(np.float32), flags, params, np.zeros(d.shape[0]))


def test_colour_powers_make_the_colour_factor():
    powers = lp.colour_powers(20.0)
    for g in (0, 1, 7, 20, 128, 255):
        product = np.prod([powers[b] for b in range(8) if g >> b & 1], dtype=np.float64)
        assert product == pytest.approx(np.exp(-g / 20.0), rel=1e-5)


def test_a_step_by_hand():
    # One row 10 10 11 11, gray, radius 1, tolerance 1: every sample counts. x = 1 sees
    # offsets -1, 0, 1 at 10, 10, 11 with the distance weights 734, 1024, 734 (the weighted
    # median's table at scale 3: round(1024 exp(-1/3)) = 734). Residuals 0, 0, 1: the mean
    # offset is 0, the slope (734 * 1) / (2 * 734 + ridge) = 0.4997, the mean residual
    # 734 / 2492 = 0.2945, so c = 0.2945 and x = 1 becomes 10.2945. By symmetry x = 2
    # becomes 11 - 0.2945.
    d = np.array([[10, 10, 11, 11]], dtype=np.float32)
    gray = np.full((1, 4), 100, dtype=np.uint8)
    out = _planes(d, gray, radius=1)
    assert out[0, 1] == pytest.approx(10 + 734 / 2492, abs=1e-5)
    assert out[0, 2] == pytest.approx(11 - 734 / 2492, abs=1e-5)
    # tolerance 0.5: the other level does not count, so the step stays
    out = _planes(d, gray, radius=1, tolerance=0.5)
    np.testing.assert_array_equal(out, d)


def test_a_colour_edge_keeps_its_step():
    # The same step on a colour edge: the other side weighs exp(-200 / 20), next to nothing
    d = np.array([[10, 10, 11, 11]], dtype=np.float32)
    guide = np.array([[0, 0, 200, 200]], dtype=np.uint8)
    out = _planes(d, guide, radius=1)
    np.testing.assert_allclose(out, d, atol=1e-3)


def test_a_plane_stays_a_plane():
    y, x = np.mgrid[0:15, 0:20]
    d = (20 + 0.3 * x - 0.2 * y).astype(np.float32)
    gray = np.full(d.shape, 90, dtype=np.uint8)
    out = _planes(d, gray)
    # the slopes' ridge pulls them by about 1e-4 of themselves: where the window is cut
    # (the edges) that moves the value by a few 1e-4 px
    np.testing.assert_allclose(out, d, atol=1e-3)
    np.testing.assert_allclose(out[4:-4, 4:-4], d[4:-4, 4:-4], atol=5e-5)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_kernel_equals_its_twin(seed):
    rng = np.random.default_rng(seed)
    height, width = 11, 17 + seed
    y, x = np.mgrid[0:height, 0:width]
    d = (20 + 0.25 * x + 0.1 * y + rng.normal(0, 0.4, (height, width))).astype(np.float32)
    d[rng.random(d.shape) < 0.1] = np.nan  # holes: neither moved nor counted
    d[rng.random(d.shape) < 0.1] += 5  # outliers beyond the tolerance
    guide = rng.integers(0, 256, (3, height, width)).astype(np.uint8)
    guide[:, :, : width // 2] //= 8  # a calmer half: weights near 1
    moved = np.isfinite(d)
    moved[2, 3] = False  # (a feature pixel's) kept as it is
    radius, tolerance = 3 if seed == 2 else 4, 1.0 + 0.5 * seed
    out = _planes(d, guide, radius, tolerance, moved)
    _, space = weight_tables(radius, lp.COLOUR_SCALE, lp.SPACE_SCALE)
    expected = naive.local_planes(d, guide, moved, radius, tolerance, lp.COLOUR_SCALE, space)
    np.testing.assert_allclose(out, expected, atol=2e-4, equal_nan=True)
    assert out[2, 3] == d[2, 3] or np.isnan(d[2, 3])


def _tall_case(seed=5, height=None, width=23):
    height = 2 * lp_kernels.BAND + 7 if height is None else height  # three bands
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:height, 0:width]
    d = (30 - 0.15 * x + 0.2 * y + rng.normal(0, 0.4, (height, width))).astype(np.float32)
    d[rng.random(d.shape) < 0.1] = np.nan
    d[rng.random(d.shape) < 0.1] -= 4
    guide = rng.integers(0, 256, (3, height, width)).astype(np.uint8)
    guide[:, height // 2 :] //= 6
    return d, guide


def test_kernel_equals_its_twin_across_bands():
    # rows past the first band take their weights of the rows above from the band's own
    # ring, which starts by computing the radius rows above the band again
    d, guide = _tall_case()
    moved = np.isfinite(d)
    out = _planes(d, guide, moved=moved)
    _, space = weight_tables(lp.RADIUS, lp.COLOUR_SCALE, lp.SPACE_SCALE)
    expected = naive.local_planes(d, guide, moved, lp.RADIUS, lp.TOLERANCE, lp.COLOUR_SCALE,
                                  space)  # fmt: skip
    np.testing.assert_allclose(out, expected, atol=2e-4, equal_nan=True)


def test_the_same_at_any_thread_count(monkeypatch):
    # bands go to whichever thread is free: one task, a few, more than bands (the counts
    # the kernel is given, whatever the machine's cores)
    d, guide = _tall_case(seed=6, height=3 * lp_kernels.BAND + 2)
    outs = []
    for threads in (1, 3, 64):
        monkeypatch.setattr(lp.nb, "get_num_threads", lambda t=threads: t)
        outs.append(_planes(d, guide))
    for out in outs[1:]:
        np.testing.assert_array_equal(outs[0], out)


def test_a_weight_is_its_samples_weight_of_the_pixel():
    # the kernel computes the weights of the forward offsets (rows below, the row to the
    # right) and takes the others from the sample: pixel p's weight of p + o is p + o's of
    # p, the same float32 product. Row 0 of a 2 x 2 image with radius 1: pixel (0, 0)'s
    # forward offsets (0, 1), (1, -1) (outside), (1, 0), (1, 1)
    guide = np.array([[[10, 30], [50, 13]]], dtype=np.int16).repeat(3, axis=0)
    _, space = weight_tables(1, lp.COLOUR_SCALE, lp.SPACE_SCALE)
    powers = lp.colour_powers(lp.COLOUR_SCALE)
    ring = np.full((4, 2), -1.0, dtype=np.float32)
    diff = np.empty(2, dtype=np.int32)
    lp_kernels.forward_weights(guide, 0, 1, powers, space.astype(np.float32), diff, ring)
    # g = 20 (10 -> 30): bits 4 and 2; g = 40 (10 -> 50): bits 5 and 3; g = 3: bits 0, 1
    factor = {20: powers[2] * powers[4], 40: powers[3] * powers[5], 3: powers[0] * powers[1]}
    assert ring[0, 0] == pytest.approx(734 * factor[20], rel=1e-6)  # (0, 1): 30
    assert ring[2, 0] == pytest.approx(734 * factor[40], rel=1e-6)  # (1, 0): 50
    assert ring[3, 0] == pytest.approx(639 * factor[3], rel=1e-6)  # (1, 1): 13
    assert ring[1, 0] == -1.0  # (1, -1) lies outside: left as it was
    # pixel (0, 1)'s forward offsets: (0, 1) outside; (1, -1): 50, g = 20; (1, 0): 13, g = 17
    assert ring[1, 1] == pytest.approx(639 * factor[20], rel=1e-6)
    assert ring[2, 1] == pytest.approx(734 * powers[0] * powers[4], rel=1e-6)
    assert ring[0, 1] == -1.0


def test_filter_limits_and_keeps_features():
    # through the filter: a feature pixel keeps its value, an estimate beyond what its
    # column can have (x - d < -0.5) is limited as the medians limit theirs
    d = np.tile(np.arange(10, dtype=np.float32) * 0.25 + 3.0, (5, 1))
    d[:, 0] = 3.6  # pixel 0 can have at most 0.5; its plane moves it (to about 3.0)
    flags = np.zeros(d.shape, np.uint8)
    flags[2, 5] = FLAG_FEATURE
    d[2, 5] = 9.0
    out = lp.local_plane_filter(_result(d, flags), np.full(d.shape, 50, np.uint8)).disparity
    assert out[2, 5] == 9.0
    assert out[0, 0] == 0.5
    np.testing.assert_allclose(out[:, 6:], d[:, 6:], atol=1e-3)


def test_a_filled_pixel_stays_in_the_searched_range():
    # a filled pixel's plane is not limited by the right image, but a plane fitted to a
    # bend extrapolates past the range: at x = 0 the weighted line through 0, 0, 0.4, 0.8
    # (the window cut at the image's edge, the values within a pixel of 0) is about -0.1,
    # below min_disparity 0
    d = np.tile(np.array([0.0, 0.0, 0.4, 0.8, 1.2, 1.6, 2.0, 2.4], np.float32), (6, 1))
    flags = np.full(d.shape, FLAG_FILLED, np.uint8)
    guide = np.full(d.shape, 50, np.uint8)
    raw = _planes(d, guide)
    assert (raw[:, 0] < -0.05).all()  # the kernel's plane, unlimited
    out = lp.local_plane_filter(_result(d, flags, max_disparity=3), guide).disparity
    assert (out[:, 0] == 0.0).all()  # limited to the range 0..3
    assert (out == np.clip(raw, 0, 3)).all()  # and nothing else moved


def test_filter_keeps_holes_and_flags_and_refuses_bad_arguments():
    d = np.full((6, 8), 12.0, dtype=np.float32)
    d[2, 2] = np.nan
    flags = np.zeros(d.shape, np.uint8)
    flags[2, 2] = FLAG_OCCLUDED
    out = lp.local_plane_filter(_result(d, flags), np.zeros((6, 8), np.uint8))
    assert np.isnan(out.disparity[2, 2]) and out.flags[2, 2] == FLAG_OCCLUDED
    np.testing.assert_array_equal(out.flags, flags)
    with pytest.raises(TypeError, match="DisparityResult"):
        lp.local_plane_filter(d, d)
    for kwargs, match in (
        ({"radius": 0}, "radius"),
        ({"tolerance": -1.0}, "tolerance"),
        ({"tolerance": float("nan")}, "tolerance"),
        ({"colour_scale": 0}, "colour_scale"),
    ):
        with pytest.raises(ValueError, match=match):
            lp.local_plane_filter(_result(d, flags), np.zeros((6, 8), np.uint8), **kwargs)
    with pytest.raises(ValueError, match="shape"):
        lp.local_plane_filter(_result(d, flags), np.zeros((5, 8), np.uint8))


def test_match_runs_it_after_the_weighted_median():
    rng = np.random.default_rng(3)
    right = rng.integers(0, 256, (30, 60), dtype=np.uint8)
    left = np.roll(right, 3, axis=1)
    planes = dcstereo.match(left, right, max_disparity=8, median="weighted-planes")
    plain = dcstereo.match(left, right, max_disparity=8, median=0)
    expected = lp.local_plane_filter(weighted_median_filter(plain, left), left)
    assert planes.disparity.tobytes() == expected.disparity.tobytes()
    assert planes.params.median == "weighted-planes"
    from dcstereo.batch.tiling import match_tiled

    tiled = match_tiled(left, right, max_disparity=8, median="weighted-planes", tile_rows=100)
    assert tiled.disparity.tobytes() == planes.disparity.tobytes()


def test_median_option_names():
    assert MatchParams(max_disparity=4, median="weighted-planes").median == "weighted-planes"
    with pytest.raises(TypeError, match="an integer, 'weighted' or 'weighted-planes'"):
        MatchParams(max_disparity=4, median="planes")


def test_cli_median_weighted_planes(pair):
    run_equals_match(pair[0], ["--median", "weighted-planes"], median="weighted-planes")


@pytest.mark.slow
@pytest.mark.dataset
@pytest.mark.parametrize(
    ("name", "options", "pinned"),
    [
        # with photometric + planes; the weighted median alone: teddy 4.645, cones 2.269
        ("teddy", {"photometric": "matched", "planes": True}, 4.570),
        ("cones", {"photometric": "matched", "planes": True}, 2.250),
    ],
)
def test_local_planes_keep_their_measured_accuracy(middlebury_root, name, options, pinned):
    bad = middlebury_bad1(middlebury_root, name, median="weighted-planes", **options)
    assert bad <= pinned + 0.01, f"{name}: bad-1.0 {bad:.3f} % > {pinned}"


@pytest.mark.slow
@pytest.mark.dataset
def test_local_planes_keep_their_measured_d1_outdoors():
    options = {"photometric": "matched", "planes": True, "median": "weighted-planes"}
    d1 = kitti_d1("kitti2012_000030_10", **options)
    assert d1 <= 3.236 + 0.01, f"D1 {d1:.3f} % > 3.236 (3.284 with the weighted median alone)"
