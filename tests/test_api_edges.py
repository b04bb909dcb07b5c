"""Edge and bad input of the public Python API: clear one-line errors, consistent results."""

import numpy as np
import pytest

import dcstereo
import synthetic
from dcstereo import METHODS, MatchParams, _checks, fill_occlusions
from dcstereo import params as params_module
from dcstereo.batch.tiling import match_tiled, row_bands
from dcstereo.evaluation import metrics
from dcstereo.methods import _bands as mbands
from dcstereo.methods.redert import match_redert
from dcstereo.signal import intensity, matching_signal, padded_signal
from dcstereo.viz.explore import compare_methods

#: Every method with every cost it takes.
METHOD_COSTS = [(m, c) for m in METHODS for c in params_module.costs_of(m)]


def pair(height=12, width=30, disparity=3):
    rng = np.random.default_rng(5)
    return synthetic.constant_pair(rng, height, width, disparity)


def same(a, b):
    np.testing.assert_array_equal(a.disparity, b.disparity)
    np.testing.assert_array_equal(a.flags, b.flags)
    np.testing.assert_array_equal(a.path_cost, b.path_cost)


# --------------------------------------------------------------------------- parameters


@pytest.mark.parametrize(
    "options",
    [
        {"max_disparity": np.int64(6)},
        {"max_disparity": np.int32(6), "min_disparity": np.int16(0)},
        {"max_disparity": 6, "window": np.int64(5)},
        {"max_disparity": 6, "occlusion_cost": np.float32(10.0), "method": "dc"},
        {"max_disparity": 6, "occlusion_cost": np.int64(10), "method": "dsi5"},
        {
            "max_disparity": 6,
            "max_candidates": np.uint8(0),
            "edge_guard": np.int64(3),
            "method": "dc",
        },
        {"max_disparity": 6, "uniqueness": np.float32(2.0), "lr_check": np.False_, "method": "dc"},
        {"max_disparity": 6, "fill": np.False_, "vs_relative": np.True_, "method": "dc"},
        {"max_disparity": 6, "p1": np.int64(30), "p2_gradient": np.float32(4.0)},
        {"max_disparity": 6, "paths": np.uint8(4), "lr_tolerance": np.int16(2)},
    ],
)
def test_numpy_scalars_are_the_numbers_they_hold(options):
    # before: "max_disparity must be an integer, got np.int64(6)"; "occlusion_cost must be
    # a finite number, got np.float32(10.0)"
    left, right = pair()
    plain = {k: v.item() if isinstance(v, np.generic) else v for k, v in options.items()}
    params = MatchParams(**options)
    assert params == MatchParams(**plain)
    for name, value in plain.items():
        assert type(getattr(params, name)) is type(value), name  # JSON-able, hashable
    same(dcstereo.match(left, right, **options), dcstereo.match(left, right, **plain))


def test_numpy_scalars_of_the_redert_options():
    params = MatchParams(
        max_disparity=6,
        method="redert",
        orientations=np.array([-0.5, 0.0, 0.5], dtype=np.float32),
        orientation_cost=np.float32(0.5),
        occlusion_discount=np.float32(0.25),
        occlusion_discount_pixels=np.int64(3),
    )
    assert params.orientations == (-0.5, 0.0, 0.5)
    assert params.occlusion_discount_pixels == 3


#: A valid value other than the default of each method's own parameter.
OTHER_VALUES = {
    "slant_cost": 1.0,
    "ser_min": 2.0,
    "vs_max": 0.5,
    "vs_relative": False,
    "feature_floor": 50.0,
    "uniqueness": 1.5,
    "edge_guard": 2,
    "lr_check": True,
    "max_candidates": 3,
    "gcp_uniqueness": 2.0,
    "gcp_variance_floor": 50.0,
    "orientations": (0.0,),
    "orientation_cost": 1.0,
    "occlusion_discount": 0.1,
    "occlusion_discount_pixels": 2,
    "occlusion_cost": 12.0,
    "census_window": (3, 5),
    "ad_truncation": 10,
    "p1": 20,
    "p2": 200,
    "p2_gradient": 4.0,
    "paths": 4,
    "lr_tolerance": 2,
    "planes": True,
    "census_step": 2,
    "census_smoothing": 1.0,
    "photometric": "matched",
    "row_alignment": "estimated",
    "edges": "support-weights",
    "aggregation": "cross",
    "cross_limit": 9,
    "cross_tau": 12,
    "cross_iterations": 2,
}


def test_every_method_option_has_a_value_to_try():
    assert set(OTHER_VALUES) == set(params_module.METHOD_OPTIONS)


@pytest.mark.parametrize("name", sorted(OTHER_VALUES))
def test_an_option_the_method_does_not_read_is_refused(name):
    # before: ignored (dcstereo.match(..., method="dsi3", ser_min=5) ran dsi3 as if it
    # had not been given); the readers accept it
    left, right = pair()
    readers = params_module.METHOD_OPTIONS[name]
    value = OTHER_VALUES[name]
    for method in METHODS:
        if method in readers:
            MatchParams(max_disparity=6, method=method, **{name: value})
            continue
        fixed = params_module.FIXED_OPTIONS.get(method, {})
        if name in fixed:  # a stage the method always runs: that value only
            assert getattr(MatchParams(max_disparity=6, method=method), name) == fixed[name]
            MatchParams(max_disparity=6, method=method, **{name: fixed[name]})
            other = {"planes": False}.get(name, "none")
            with pytest.raises(ValueError, match=f"{name}={other!r}: {method} always runs"):
                MatchParams(max_disparity=6, method=method, **{name: other})
            continue
        with pytest.raises(ValueError) as err:
            dcstereo.match(left, right, max_disparity=6, method=method, **{name: value})
        assert str(err.value) == f"{name} is read only by {', '.join(readers)}, not by {method}"
        # the default, given explicitly, changes nothing and is accepted
        default = getattr(MatchParams(max_disparity=6), name)
        MatchParams(max_disparity=6, method=method, **{name: default})


def test_the_tools_of_several_methods_give_each_method_its_own_options():
    left, right = pair(height=12, width=40)
    # a variance floor above every pixel: dc finds no pair; dsi3 and block run as without it
    results = compare_methods(
        left,
        right,
        max_disparity=6,
        methods=["dsi3", "dc", "block"],
        match_options={"feature_floor": 1e9},
    )
    assert len(results["dc"].features) == 0
    assert len(dcstereo.match(left, right, max_disparity=6, method="dc").features) > 0
    same(results["dsi3"], dcstereo.match(left, right, max_disparity=6, method="dsi3"))
    same(results["block"], dcstereo.match(left, right, max_disparity=6, method="block"))
    with pytest.raises(ValueError, match="^ser_min is read only by dc, dc-linear, none of the"):
        compare_methods(
            left, right, max_disparity=6, methods=["dsi3", "block"], match_options={"ser_min": 2}
        )
    assert params_module.options_for("dsi3+bt", {"ser_min": 2, "window": 3}) == {"window": 3}
    assert params_module.options_for("dc+bt", {"ser_min": 2}) == {"ser_min": 2}
    assert params_module.options_for("opencv-sgbm", {"orientations": (0.0,)}) == {}


#: Not True or False; fill=None is the method's default (test_method_defaults_fill_in_none).
NOT_SWITCHES = [
    (name, value)
    for name in ("fill", "vs_relative", "lr_check")
    for value in ("no", None, 1, np.array([True]))
    if not (name == "fill" and value is None)
]


@pytest.mark.parametrize(("name", "value"), NOT_SWITCHES)
def test_switches_must_be_true_or_false(name, value):
    # before: any object went by its truth value, so fill="no" filled
    with pytest.raises(TypeError, match=f"{name} must be True or False"):
        MatchParams(max_disparity=4, method="dc", **{name: value})


@pytest.mark.parametrize("method", METHODS)
def test_method_defaults_fill_in_none(method):
    defaults = params_module.METHOD_DEFAULTS.get(method, params_module.METHOD_DEFAULTS[None])
    given = MatchParams(max_disparity=4, method=method, **dict.fromkeys(defaults))
    for name, value in defaults.items():
        assert getattr(given, name) == value
        assert getattr(MatchParams(max_disparity=4, method=method), name) == value
    assert MatchParams(max_disparity=4).method == dcstereo.DEFAULT_METHOD == "sgm"


@pytest.mark.parametrize("method", ["dc", "dc-linear"])
@pytest.mark.parametrize("option", ["edge_guard", "max_candidates"])
def test_limits_beyond_int64_are_those_of_the_width(method, option):
    # before: OverflowError "int too big to convert" from the kernel's dispatcher
    left, right = pair()
    width = left.shape[1]
    huge = dcstereo.match(left, right, max_disparity=6, method=method, **{option: 2**70})
    same(huge, dcstereo.match(left, right, max_disparity=6, method=method, **{option: width}))


def test_out_of_memory_in_a_parallel_kernel_is_a_memory_error(monkeypatch):
    # numba turns a failed allocation in a parallel region into "SystemError:
    # CPUDispatcher(...) returned a result with an exception set" (reproduced on a
    # 1 x 40000 pair with max_disparity=39999 under ``ulimit -v 6000000``)
    def out_of_memory(*args):
        try:
            raise MemoryError("Allocation failed (probably too large).")
        except MemoryError as err:
            raise SystemError("CPUDispatcher(...) returned a result with an exception set") from err

    monkeypatch.setattr(mbands.bands, "match_band_rows", out_of_memory)
    left, right = pair()
    with pytest.raises(MemoryError, match=r"out of memory matching 12 x 30 images over 7 disp"):
        dcstereo.match(left, right, max_disparity=6, method="dsi3")

    def other(*args):
        raise SystemError("something else")

    monkeypatch.setattr(mbands.bands, "match_band_rows", other)
    with pytest.raises(SystemError, match="something else"):
        dcstereo.match(left, right, max_disparity=6, method="dsi3")


# --------------------------------------------------------------------------- images


@pytest.mark.parametrize(("method", "cost"), METHOD_COSTS)
def test_big_endian_uint16_is_uint16(method, cost):
    # before: TypeError "left image has dtype >u2; expected uint8, uint16 ..." (16-bit
    # PGM and PNG data are big-endian)
    left, right = pair()
    native = [(image.astype(np.uint16) * 257) for image in (left, right)]
    swapped = [image.astype(">u2") for image in native]
    options = {"max_disparity": 6, "method": method, "cost": cost}
    same(dcstereo.match(*swapped, **options), dcstereo.match(*native, **options))
    colour = [np.stack([image] * 3, axis=-1) for image in swapped]
    same(dcstereo.match(*colour, **options), dcstereo.match(*native, **options))


def test_signal_helpers_read_big_endian_uint16():
    # before: intensity and padded_signal took ">u2" for a float image (x 255)
    image = (pair()[0].astype(np.uint16) * 257)[:, :7]
    swapped = image.astype(">u2")
    np.testing.assert_array_equal(intensity(swapped), intensity(image))
    np.testing.assert_array_equal(matching_signal(swapped), matching_signal(image))
    np.testing.assert_array_equal(padded_signal(swapped, 2), padded_signal(image, 2))


def test_nan_pixels_of_a_colour_image_are_counted_once():
    # before: "left image has 6 NaN or infinite pixel(s)" for 2 pixels of 3 channels
    left, right = pair()
    colour = np.stack([left / 255.0] * 3, axis=-1)
    colour[0, :2] = np.nan
    with pytest.raises(ValueError, match=r"left image has 2 NaN or infinite pixel\(s\)"):
        dcstereo.match(colour, right, max_disparity=4)


def test_ragged_list_is_not_an_image():
    # before: numpy's "setting an array element with a sequence. ..."
    left, right = pair()
    with pytest.raises(ValueError, match="left image is not a rectangular array"):
        dcstereo.match([[0.1, 0.2], [0.3]], right, max_disparity=4)


@pytest.mark.parametrize(("method", "cost"), METHOD_COSTS)
def test_layouts_of_one_picture_give_one_map_and_leave_it_alone(method, cost):
    left, right = pair()
    options = {"max_disparity": 6, "method": method, "cost": cost}
    base = dcstereo.match(left, right, **options)
    wide = np.zeros((2, *left.shape[::-1]), dtype=np.uint8)  # strided views
    wide[0], wide[1] = left.T, right.T
    frozen = [image.copy() for image in (left, right)]
    for image in frozen:
        image.flags.writeable = False
    layouts = [
        (np.asfortranarray(left), np.asfortranarray(right)),
        (left.T.copy().T, right.T.copy().T),
        (wide[0].T, wide[1].T),
        (left[::-1].copy()[::-1], right[:, ::-1].copy()[:, ::-1]),
        tuple(frozen),
        (left[..., None], (right / 255.0).astype(np.float32)),
    ]
    for a, b in layouts:
        before = (a.copy(), b.copy())
        same(dcstereo.match(a, b, **options), base)
        np.testing.assert_array_equal(a, before[0])
        np.testing.assert_array_equal(b, before[1])


# --------------------------------------------------------------------------- helpers


@pytest.mark.parametrize(
    ("disparity", "error", "message"),
    [
        (np.array([1.0, np.nan]), ValueError, r"2-D \(H, W\) array, got shape \(2,\)"),
        (np.float32(1.0), ValueError, r"got shape \(\)"),
        (np.zeros((1, 2, 3)), ValueError, r"got shape \(1, 2, 3\)"),
        (None, TypeError, "dtype object"),
        (np.zeros((2, 2), dtype=complex), TypeError, "dtype complex128"),
        (np.zeros((2, 2), dtype=bool), TypeError, "dtype bool"),
    ],
)
def test_fill_occlusions_refuses_what_is_not_a_disparity_map(disparity, error, message):
    # before: "not enough values to unpack", or a complex map silently made real
    with pytest.raises(error, match=message):
        fill_occlusions(disparity)


def test_fill_occlusions_leaves_its_input_alone():
    d = np.array([[np.nan, 1, np.nan, 3, np.nan]], dtype=np.float32)
    d.flags.writeable = False
    filled, was_filled = fill_occlusions(d[:, ::-1])
    np.testing.assert_array_equal(filled, [[3, 3, 1, 1, 1]])
    assert np.isnan(d[0, ::2]).all()


@pytest.mark.parametrize(
    ("threshold", "error"),
    [("1", TypeError), (None, TypeError), (True, TypeError), ([1], TypeError), (-1, ValueError)],
)
def test_threshold_must_be_a_number(threshold, error):
    # before: "1" and True were taken as 1.0; None and [1] failed inside float()
    truth = np.array([[1.0, 2.0]])
    with pytest.raises(error, match="threshold must be a"):
        metrics.bad_pixel_rate(truth, truth, threshold=threshold)


def test_threshold_of_numpy_type_is_accepted():
    truth = np.array([[1.0, 2.0]])
    assert metrics.bad_pixel_rate(truth + 0.75, truth, threshold=np.float32(0.5)) == 100.0


@pytest.mark.parametrize(
    ("masks", "thresholds", "message"),
    [
        ([np.ones((1, 2), bool)], (1.0,), "masks must be a mapping of names to boolean arrays"),
        (None, (1.0,), "masks must be a mapping"),
        ({"all": np.ones((1, 2), bool)}, 1.0, "thresholds must be a sequence of numbers"),
        ({"all": np.ones((1, 2), bool)}, "0.5", "thresholds must be a sequence of numbers"),
    ],
)
def test_evaluate_refuses_masks_and_thresholds_of_the_wrong_kind(masks, thresholds, message):
    # before: AttributeError "'list' object has no attribute 'items'", "'float' object is
    # not iterable", and "0.5" read as the thresholds "0", ".", "5"
    truth = np.array([[1.0, 2.0]])
    with pytest.raises(TypeError, match=message):
        metrics.evaluate(truth, truth, masks, thresholds)


@pytest.mark.parametrize(
    ("args", "error", "message"),
    [
        ((-1, 4, 3), ValueError, "height must be 0 or positive, got -1"),
        ((10.0, 4, 3), TypeError, "height must be an integer, got 10.0"),
        ((True, 4, 3), TypeError, "height must be an integer, got True"),
        ((10, 4, 4), ValueError, "window must be a positive odd integer, got 4"),
        ((10, 4, -3), ValueError, "window must be a positive odd integer, got -3"),
        ((10, 4, 3.0), TypeError, "window must be an integer, got 3.0"),
    ],
)
def test_row_bands_refuses_bad_arguments(args, error, message):
    # before: [] for a negative height; bands reading rows 2..2 (nothing) for window -3
    with pytest.raises(error, match=message):
        row_bands(*args)


def test_row_bands_of_numpy_integers_hold_python_integers():
    bands = row_bands(np.int64(10), np.int32(4), np.int64(3))
    assert bands == row_bands(10, 4, 3)
    assert all(type(value) is int for band in bands for value in vars(band).values())


def test_match_tiled_takes_numpy_integers():
    left, right = pair()
    tiled = match_tiled(left, right, tile_rows=np.int64(5), max_disparity=np.int64(6))
    same(tiled, dcstereo.match(left, right, max_disparity=6))


def test_match_redert_refuses_other_params():
    # before: AttributeError "'dict' object has no attribute 'check_image_size'", and
    # cost="bt" (allowed with the other methods' params) silently matched with SAD
    left, right = pair()
    with pytest.raises(TypeError, match="params must be a MatchParams, got dict"):
        match_redert(left, right, {"max_disparity": 4})
    with pytest.raises(ValueError, match="cost='bt' is not supported by redert"):
        match_redert(left, right, MatchParams(max_disparity=4, method="dc", cost="bt"))


def test_masked_image_with_masked_pixels_is_refused_not_matched_under_its_mask():
    rng = np.random.default_rng(5)
    right = rng.integers(0, 256, (8, 20), dtype=np.uint8)
    left = np.roll(right, 2, axis=1)
    masked = np.ma.masked_array(left, mask=np.zeros(left.shape, bool))
    plain = dcstereo.match(left, right, max_disparity=4, method="dsi3")
    assert np.array_equal(  # nothing masked: the values are the image
        dcstereo.match(masked, right, max_disparity=4, method="dsi3").disparity,
        plain.disparity,
        equal_nan=True,
    )
    masked[3, 4] = np.ma.masked
    with pytest.raises(ValueError, match="^left image is a masked array with masked pixels"):
        dcstereo.match(masked, right, max_disparity=4, method="dsi3")


@pytest.mark.parametrize(
    ("value", "integer", "number"),
    [
        (3, True, True),
        (np.int64(3), True, True),
        (np.uint8(3), True, True),
        (3.0, False, True),
        (np.float32(0.5), False, True),
        (True, False, False),
        (np.True_, False, False),
        ("3", False, False),
        (None, False, False),
        (1j, False, False),
        (np.complex128(1), False, False),
        (np.array(3), False, False),
    ],
)
def test_one_meaning_of_integer_and_number(value, integer, number):
    assert _checks.is_integer(value) is integer
    assert _checks.is_number(value) is number


def _result_parts():
    d = np.array([[0.0, np.nan, 1.5, 1.0]], np.float32)
    flags = np.array([[0, dcstereo.FLAG_OCCLUDED, 0, 0]], np.uint8)
    return dict(disparity=d, flags=flags, params=MatchParams(max_disparity=4),
                path_cost=np.zeros(1), features=np.zeros((0, 5)))  # fmt: skip


def test_a_disparity_result_built_by_hand_works_like_a_matched_one():
    result = dcstereo.DisparityResult(**_result_parts())
    np.testing.assert_array_equal(result.filled().disparity, [[0.0, 0.0, 1.5, 1.0]])
    np.testing.assert_array_equal(result.pairs(), [[0, 0, 0], [0, 3, 2]])
    assert result.method == "sgm" and result.occluded.tolist() == [[False, True, False, False]]


@pytest.mark.parametrize(
    "name, value, message",
    [
        ("disparity", np.zeros((1, 4)), r"disparity must be a float32 \(H, W\) array, got "
         r"float64 array of shape \(1, 4\)"),
        ("disparity", np.zeros(3, np.float32), "got float32 array of shape"),
        ("disparity", [[1.0, 2.0, 3.0]], "got list"),
        ("flags", np.zeros((1, 4), np.int64), r"flags must be a uint8 array of shape \(1, 4\)"),
        ("flags", np.zeros((4, 1), np.uint8), r"got uint8 array of shape \(4, 1\)"),
        ("path_cost", np.zeros(2), r"path_cost must be a float array of shape \(1,\)"),
        ("path_cost", np.zeros(1, int), "got int64 array"),
        ("features", np.zeros((2, 4)), r"features must be None or a float \(M, 5\) array"),
        ("features", "none", "got str"),
        ("params", {"method": "dc"}, r"params must be the run's parameters \(MatchParams\), "
         "got dict"),
    ],
)  # fmt: skip
def test_a_disparity_result_of_the_wrong_parts_is_refused(name, value, message):
    parts = _result_parts() | {name: value}
    with pytest.raises(TypeError, match=message):
        dcstereo.DisparityResult(**parts)
