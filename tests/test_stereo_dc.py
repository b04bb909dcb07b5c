"""StereoDC: OpenCV's StereoSGBM interface over dcstereo.match, checked against OpenCV."""

import functools
import inspect

import numpy as np
import pytest

import dcstereo
import synthetic
from dcstereo.compat import stereo_dc
from dcstereo.compat.stereo_dc import OPENCV_OPTIONS, StereoDC, to_fixed_point
from dcstereo.geometry import Calibration, depth, point_cloud

cv2 = pytest.importorskip("cv2")

HEIGHT, WIDTH = 40, 96


def gray_pair(seed=7):
    """A textured object (disparity 11) before a background (disparity 4), and the truth."""
    rng = np.random.default_rng(seed)
    return synthetic.object_pair(rng, HEIGHT, WIDTH, 4, 11, (40, 70))


def colour_pair(seed=8):
    """An RGB pair whose channels differ (each a shifted texture of its own)."""
    rng = np.random.default_rng(seed)
    right = np.stack([synthetic.texture(rng, HEIGHT, WIDTH + 8) for _ in range(3)], axis=2)
    left = right[:, :WIDTH].copy()
    right = right[:, 5 : WIDTH + 5].copy()  # left x matches right x - 5
    return left, right


def expected_fixed(disparity, low, high):
    """OpenCV's format of a float map, written out: round(16 d), (low - 1) * 16 for none."""
    out = np.full(disparity.shape, (low - 1) * 16, dtype=np.int64)
    finite = np.isfinite(disparity)
    out[finite] = np.clip(np.rint(16 * disparity[finite].astype(np.float64)), 16 * low, 16 * high)
    return out.astype(np.int16)


@pytest.mark.parametrize("low", [0, -3])
def test_format_matches_opencv_on_the_same_pair(low):
    left, right, _ = gray_pair()
    settings = {"minDisparity": low, "numDisparities": 16, "blockSize": 5}
    theirs = cv2.StereoSGBM_create(**settings).compute(left, right)
    ours = StereoDC.create(**settings).compute(left, right)
    assert ours.dtype == theirs.dtype == np.int16
    assert ours.shape == theirs.shape == left.shape
    # the sentinel: OpenCV marks its pixels without an estimate (min - 1) * 16, and so do we
    sentinel = (low - 1) * 16
    assert set(np.unique(theirs[theirs < low * 16])) == {sentinel}
    # the default method (sgm) fills its map: every pixel has a disparity; without its
    # fill, the pixels without an estimate have the sentinel
    assert (ours >= low * 16).all()
    unfilled = StereoDC.create(**settings, fill=False).compute(left, right)
    assert set(np.unique(unfilled[unfilled < low * 16])) == {sentinel}
    assert ours.max() <= (low + 15) * 16 and unfilled.max() <= (low + 15) * 16
    # the same disparities where both have one: within a pixel almost everywhere
    both = (ours != sentinel) & (theirs != sentinel)
    assert both.mean() > 0.6
    close = np.abs(ours[both].astype(int) - theirs[both].astype(int)) <= 16
    assert close.mean() > 0.95


@pytest.mark.parametrize("options", [{}, {"fill": False}, {"method": "dc"}])
def test_values_are_those_of_match(options):
    left, right, _ = gray_pair()
    result = dcstereo.match(left, right, max_disparity=15, min_disparity=0, window=5, **options)
    ours = StereoDC.create(0, 16, 5, **options).compute(left, right)
    np.testing.assert_array_equal(ours, expected_fixed(result.disparity, 0, 15))
    # sgm, the default, fills its map; unfilled, some pixels have the sentinel
    assert np.isnan(result.disparity).any() == bool(options)


@pytest.mark.parametrize(
    "options",
    [
        {"fill": False},
        {"subpixel": "parabola"},
        {"p2": 300, "median": 3},
        {"method": "dc", "fill": True},
        {"method": "dc", "occlusion_cost": 5.0, "median": 3},
    ],
)
def test_our_options_reach_match(options):
    left, right, _ = gray_pair()
    result = dcstereo.match(left, right, max_disparity=20, min_disparity=2, **options)
    ours = StereoDC.create(minDisparity=2, numDisparities=19, **options).compute(left, right)
    np.testing.assert_array_equal(ours, expected_fixed(result.disparity, 2, 20))
    if "subpixel" in options:  # fractions of a pixel survive in 1/16 steps
        assert (ours % 16 != 0).any()


def test_the_default_method_is_matchs_and_read_from_it(monkeypatch):
    assert StereoDC().getMethod() == inspect.signature(dcstereo.match).parameters["method"].default
    assert "method" not in StereoDC().match_keywords()  # match's own default runs

    real = stereo_dc.match

    def match_with_another_default(left, right, *, max_disparity, min_disparity=0,
                                   method="dsi5", **options):  # fmt: skip
        return real(left, right, max_disparity=max_disparity, min_disparity=min_disparity,
                    method=method, **options)  # fmt: skip

    monkeypatch.setattr(stereo_dc, "match", match_with_another_default)
    matcher = StereoDC.create(numDisparities=16)
    assert matcher.getMethod() == "dsi5" and matcher.params().method == "dsi5"
    left, right, _ = gray_pair()
    result = dcstereo.match(left, right, max_disparity=15, method="dsi5")
    np.testing.assert_array_equal(
        matcher.compute(left, right), expected_fixed(result.disparity, 0, 15)
    )


def test_another_method_by_name():
    left, right, _ = gray_pair()
    matcher = StereoDC.create(numDisparities=16, method="block")
    result = dcstereo.match(left, right, max_disparity=15, method="block")
    np.testing.assert_array_equal(
        matcher.compute(left, right), expected_fixed(result.disparity, 0, 15)
    )
    matcher.setMethod(None)
    assert matcher.getMethod() == stereo_dc.default_method()


def test_colour_is_taken_as_bgr_unless_told(monkeypatch):
    rgb_left, rgb_right = colour_pair()
    bgr_left, bgr_right = rgb_left[:, :, ::-1], rgb_right[:, :, ::-1]
    seen = []
    real = stereo_dc.match

    @functools.wraps(real)  # match's signature, default method included
    def spy(left, right, **keywords):
        seen.append((left, right))
        return real(left, right, **keywords)

    monkeypatch.setattr(stereo_dc, "match", spy)
    bgr = StereoDC.create(numDisparities=16).compute(bgr_left, bgr_right)
    np.testing.assert_array_equal(seen[-1][0], rgb_left)
    np.testing.assert_array_equal(seen[-1][1], rgb_right)
    rgb = StereoDC.create(numDisparities=16, color_order="RGB").compute(rgb_left, rgb_right)
    np.testing.assert_array_equal(seen[-1][0], rgb_left)
    np.testing.assert_array_equal(bgr, rgb)
    expected = real(rgb_left, rgb_right, max_disparity=15).disparity
    np.testing.assert_array_equal(bgr, expected_fixed(expected, 0, 15))
    # BGRA (cv2.IMREAD_UNCHANGED of a PNG with alpha): the alpha is dropped, the order kept
    alpha = np.full(bgr_left.shape[:2] + (1,), 255, dtype=np.uint8)
    StereoDC.create(numDisparities=16).compute(
        np.concatenate([bgr_left, alpha], axis=2), np.concatenate([bgr_right, alpha], axis=2)
    )
    np.testing.assert_array_equal(seen[-1][0], rgb_left)


def test_gray_and_other_dtypes():
    left, right, _ = gray_pair()
    matcher = StereoDC.create(numDisparities=16)
    as_uint8 = matcher.compute(left, right)
    np.testing.assert_array_equal(matcher.compute(left / 255.0, right / 255.0), as_uint8)
    np.testing.assert_array_equal(
        matcher.compute(left.astype(np.uint16) * 257, right.astype(np.uint16) * 257), as_uint8
    )


def test_reprojection_round_trip_with_opencv():
    left, right, _ = gray_pair()
    calibration = Calibration(focal=420.0, baseline=120.0, cx=47.5, cy=19.5, doffs=3.0)
    matcher = StereoDC.create(minDisparity=0, numDisparities=16, blockSize=5)
    fixed = matcher.compute(left, right)
    points = cv2.reprojectImageTo3D(
        fixed.astype(np.float32) / 16, calibration.reprojection_matrix()
    )
    # the disparities OpenCV reprojects: sgm's sub-pixel estimates in 1/16 pixel steps
    disparity = matcher.match(left, right).disparity
    np.testing.assert_array_equal(to_fixed_point(disparity, 0, 15), fixed)
    disparity = np.where(fixed >= 0, fixed / np.float32(16), np.float32(np.nan))
    z = depth(disparity, calibration)
    known = np.isfinite(z)
    assert known.mean() > 0.6
    np.testing.assert_allclose(points[..., 2][known], z[known], rtol=1e-5)
    cloud = point_cloud(disparity, calibration)
    rows, cols = cloud.pixels.T
    np.testing.assert_allclose(points[rows, cols], cloud.points, rtol=1e-5, atol=1e-3)
    # and a non-square pixel: the second row of Q carries focal / focal_y
    tall = Calibration(focal=420.0, baseline=120.0, cx=47.5, cy=19.5, focal_y=400.0)
    points = cv2.reprojectImageTo3D(fixed.astype(np.float32) / 16, tall.reprojection_matrix())
    cloud = point_cloud(disparity, tall)
    rows, cols = cloud.pixels.T
    np.testing.assert_allclose(points[rows, cols], cloud.points, rtol=1e-5, atol=1e-3)


def test_out_argument_as_opencv():
    left, right, _ = gray_pair()
    matcher = StereoDC.create(numDisparities=16)
    out = np.zeros(left.shape, dtype=np.int16)
    returned = matcher.compute(left, right, out)
    assert returned is out
    np.testing.assert_array_equal(out, matcher.compute(left, right))
    with pytest.raises(TypeError, match="disparity must be a writable int16 array"):
        matcher.compute(left, right, np.zeros(left.shape, dtype=np.float32))
    with pytest.raises(ValueError, match=r"disparity has shape \(3, 3\)"):
        matcher.compute(left, right, np.zeros((3, 3), dtype=np.int16))


def test_every_getter_and_setter_of_opencv_is_there():
    names = [
        n for n in dir(cv2.StereoSGBM) if n.startswith(("get", "set")) and n != "setDefaultName"
    ]
    assert names
    missing = [name for name in names if not hasattr(StereoDC, name)]
    assert missing == []
    # OpenCV's defaults for every setting but the range and the window
    theirs, ours = cv2.StereoSGBM_create(), StereoDC.create()
    for row in OPENCV_OPTIONS:
        getter = "get" + row.name[0].upper() + row.name[1:]
        if row.name not in ("numDisparities", "blockSize"):
            assert getattr(ours, getter)() == getattr(theirs, getter)(), row.name


def test_setters_change_and_check():
    matcher = StereoDC.create()
    for row in OPENCV_OPTIONS:
        stem = row.name[0].upper() + row.name[1:]
        value = {"blockSize": 7, "numDisparities": 32, "mode": StereoDC.MODE_HH}.get(row.name, 3)
        getattr(matcher, "set" + stem)(value)
        assert getattr(matcher, "get" + stem)() == value
    # sgm reads disp12MaxDiff (its lr_tolerance) and mode (its paths: 8 but for MODE_HH4)
    assert matcher.match_keywords() == {
        "min_disparity": 3, "max_disparity": 34, "window": 7, "lr_tolerance": 3, "paths": 8,
    }  # fmt: skip
    matcher.setMethod("dc")  # the paper's method has neither
    assert matcher.match_keywords() == {
        "min_disparity": 3, "max_disparity": 34, "window": 7, "method": "dc",
    }  # fmt: skip
    matcher.setMethod(None)
    with pytest.raises(ValueError, match="blockSize must be a positive odd integer, got 4"):
        matcher.setBlockSize(4)
    assert matcher.getBlockSize() == 7  # a refused change changes nothing
    with pytest.raises(TypeError, match="numDisparities must be an integer"):
        matcher.setNumDisparities(16.5)
    with pytest.raises(ValueError, match="numDisparities must be at least 1"):
        matcher.setNumDisparities(0)
    with pytest.raises(ValueError, match="mode must be one of"):
        matcher.setMode(7)
    matcher.setMatchOptions(fill=True)
    assert matcher.getMatchOptions() == {"fill": True} and matcher.match_keywords()["fill"]
    with pytest.raises(ValueError, match="occlusion_cost must be positive"):
        matcher.setMatchOptions(occlusion_cost=-1.0)
    assert matcher.getMatchOptions() == {"fill": True}
    matcher.setColorOrder("RGB")
    assert matcher.getColorOrder() == "RGB"
    with pytest.raises(ValueError, match="color_order must be 'BGR' or 'RGB'"):
        matcher.setColorOrder("YUV")
    assert not matcher.empty() and matcher.getDefaultName() == "dcstereo.StereoDC"
    matcher.clear()
    assert "numDisparities=32" in repr(matcher)


def test_block_size_defaults_to_the_methods_window():
    matcher = StereoDC.create(numDisparities=16)
    assert "window" not in matcher.match_keywords()
    assert matcher.getBlockSize() == dcstereo.MatchParams(max_disparity=15).window


def test_opencv_usual_arguments_are_accepted_without_effect():
    left, right, _ = gray_pair()
    usual = dict(
        minDisparity=0,
        numDisparities=16,
        blockSize=5,
        P1=8 * 3 * 25,
        P2=32 * 3 * 25,
        disp12MaxDiff=1,
        preFilterCap=63,
        uniquenessRatio=10,
        speckleWindowSize=100,
        speckleRange=32,
        mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY,
    )
    matcher = StereoDC.create(**usual)
    assert matcher.getP2() == 32 * 3 * 25 and matcher.getMode() == 2
    # sgm, the default, reads disp12MaxDiff and mode (here its own defaults, 1 and 8
    # paths); the others change nothing
    assert matcher.unusedOptions() == [
        "P1", "P2", "preFilterCap", "uniquenessRatio", "speckleWindowSize", "speckleRange",
    ]  # fmt: skip
    assert matcher.match_keywords() == {
        "min_disparity": 0, "max_disparity": 15, "window": 5, "lr_tolerance": 1, "paths": 8,
    }  # fmt: skip
    plain = StereoDC.create(minDisparity=0, numDisparities=16, blockSize=5)
    assert plain.unusedOptions() == []
    np.testing.assert_array_equal(matcher.compute(left, right), plain.compute(left, right))
    positional = StereoDC.create(*usual.values())
    assert positional.match_keywords() == matcher.match_keywords()
    # the paper's dc reads none of them
    dc = StereoDC.create(**usual, method="dc")
    assert dc.unusedOptions() == [
        "P1", "P2", "disp12MaxDiff", "preFilterCap", "uniquenessRatio",
        "speckleWindowSize", "speckleRange", "mode",
    ]  # fmt: skip
    plain_dc = StereoDC.create(minDisparity=0, numDisparities=16, blockSize=5, method="dc")
    assert dc.match_keywords() == plain_dc.match_keywords()
    np.testing.assert_array_equal(dc.compute(left, right), plain_dc.compute(left, right))
    with pytest.raises(ValueError, match="P1 has no effect with method"):
        StereoDC.create(numDisparities=16, P1=200, strict=True)
    StereoDC.create(numDisparities=16, P1=0, strict=True)  # OpenCV's default: fine


@pytest.mark.parametrize(
    ("setting", "value", "keyword", "expected"),
    [
        ("disp12MaxDiff", 3, "lr_tolerance", 3),
        ("disp12MaxDiff", -1, "lr_tolerance", None),  # OpenCV's "no check"
        ("mode", StereoDC.MODE_HH4, "paths", 4),
        ("mode", StereoDC.MODE_HH, "paths", 8),
    ],
)
def test_disp12maxdiff_and_mode_reach_sgm_not_dc(setting, value, keyword, expected):
    left, right, _ = gray_pair()
    matcher = StereoDC.create(numDisparities=16, **{setting: value})
    assert matcher.match_keywords()[keyword] == expected and matcher.unusedOptions() == []
    result = dcstereo.match(left, right, max_disparity=15, **{keyword: expected})
    fixed = matcher.compute(left, right)
    np.testing.assert_array_equal(fixed, expected_fixed(result.disparity, 0, 15))
    if expected not in (1, 8):  # not sgm's own default: the map changes
        assert (fixed != StereoDC.create(numDisparities=16).compute(left, right)).any()
    # the paper's dc has no such setting: kept, without effect, or refused when strict
    dc = StereoDC.create(numDisparities=16, method="dc", **{setting: value})
    assert keyword not in dc.match_keywords() and dc.unusedOptions() == [setting]
    with pytest.raises(ValueError, match=f"{setting} has no effect with method 'dc'"):
        StereoDC.create(numDisparities=16, method="dc", strict=True, **{setting: value})


def test_a_mapped_setting_reaches_match(monkeypatch):
    # a method that reads an equivalent gets the value (here the table maps speckleRange
    # onto dc's `uniqueness`, as disp12MaxDiff and mode are mapped onto sgm's keywords)
    rows = tuple(
        stereo_dc.OpenCVOption(row.name, row.default, "uniqueness", lambda v: v / 10, "test")
        if row.name == "speckleRange"
        else row
        for row in OPENCV_OPTIONS
    )
    monkeypatch.setattr(stereo_dc, "OPENCV_OPTIONS", rows)
    matcher = StereoDC.create(numDisparities=16, speckleRange=35, method="dc")
    assert matcher.match_keywords()["uniqueness"] == 3.5 and matcher.unusedOptions() == []
    assert "uniqueness" not in StereoDC.create(numDisparities=16, method="dsi3").match_keywords()
    assert StereoDC.create(numDisparities=16, speckleRange=35, method="dsi3").unusedOptions() == [
        "speckleRange"
    ]


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"blockSize": 0}, ValueError, "blockSize must be a positive odd integer"),
        ({"numDisparities": 2100}, ValueError, "does not fit OpenCV's int16 fixed point"),
        ({"minDisparity": -3000}, ValueError, "minDisparity must be from -2047"),
        ({"minDisparity": 1.5}, TypeError, "minDisparity must be an integer"),
        ({"P1": -1}, ValueError, "P1 must be 0 or more"),
        ({"window": 5}, ValueError, "window is set by blockSize"),
        ({"max_disparity": 5}, ValueError, "max_disparity is set by numDisparities"),
        ({"method": "sgm?"}, ValueError, "unknown method 'sgm\\?'"),
        ({"ser_min": 2.0, "method": "dsi3"}, ValueError, "ser_min is read only by"),
        ({"color_order": "rgb"}, ValueError, "color_order must be"),
        ({"strict": 1}, TypeError, "strict must be True or False"),
    ],
)
def test_bad_settings_are_named(kwargs, error, message):
    with pytest.raises(error, match=message):
        StereoDC.create(**kwargs)


def test_bad_images_are_named():
    left, right, _ = gray_pair()
    matcher = StereoDC.create(numDisparities=16)
    with pytest.raises(ValueError, match="differ in shape"):
        matcher.compute(left, right[:, :-1])
    with pytest.raises(TypeError, match="left image has dtype int32"):
        matcher.compute(left.astype(np.int32), right)
    with pytest.raises(ValueError, match="does not fit an image 12 pixels wide"):
        StereoDC.create(numDisparities=16).compute(left[:, :12], right[:, :12])


def test_to_fixed_point_rounds_and_clips():
    d = np.array([[0.0, 1.03, 2.5, np.nan, 7.9, -0.2]])
    np.testing.assert_array_equal(to_fixed_point(d, 0, 7), [[0, 16, 40, -16, 112, 0]])
