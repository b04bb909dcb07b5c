"""The smoothing of the intensity before the census (``census_smoothing``): kernel, use, pins."""

import math

import numpy as np
import pytest

import dcstereo
import naive_smoothing
from cli_runs import run_equals_match
from dcstereo.costs import smoothing
from dcstereo.params import MatchParams
from pins import kitti_d1


def test_weights_by_hand():
    # sigma 0.3: radius round(4 * 0.3) = 1; exp(-1 / 0.18) = 0.003866 of the centre's
    # weight, 4096 * 0.003866 / 1.007732 = 15.7 -> 16 a side, the centre 4096 - 32 = 4064
    assert smoothing.gaussian_weights(0.3).tolist() == [16, 4064, 16]
    assert smoothing.gaussian_weights(0).tolist() == [4096]


@pytest.mark.parametrize("sigma", [0.5, 1.2, 2.0, 4.0])
def test_weights_sum_exactly_and_are_a_gaussian(sigma):
    weights = smoothing.gaussian_weights(sigma)
    radius = int(smoothing.TRUNCATE * sigma + 0.5)
    assert weights.size == 2 * radius + 1
    assert weights.sum() == 1 << smoothing.WEIGHT_BITS
    np.testing.assert_array_equal(weights, weights[::-1])
    g = np.exp(-(np.arange(-radius, radius + 1) ** 2) / (2 * sigma * sigma))
    np.testing.assert_allclose(weights / weights.sum(), g / g.sum(), atol=1.5 / 4096)


def test_smoothing_by_hand():
    # one row 0 1000 0, sigma 0.3 (weights 16 4064 16): the column sums are 4096 times the
    # row; x = 0: 4096 * 16 * 1000 / 2**24 = 3.9 -> 4; x = 1: 4096 * 4064 * 1000 / 2**24
    # = 992.2 -> 992
    signal = np.array([[0, 1000, 0]], dtype=np.int32)
    assert smoothing.smooth_signal(signal, 0.3).tolist() == [[4, 992, 4]]


@pytest.mark.parametrize(
    ("shape", "sigma"),
    [((1, 1), 1.0), ((1, 9), 1.2), ((7, 1), 0.8), ((6, 11), 1.2), ((13, 9), 2.5), ((5, 4), 4.0)],
)
def test_kernel_equals_its_twin(shape, sigma):
    rng = np.random.default_rng(shape[0] * 31 + shape[1])
    signal = rng.integers(0, 255 * 16 + 1, shape).astype(np.int32)
    weights = smoothing.gaussian_weights(sigma)
    expected = naive_smoothing.smooth(signal, weights, smoothing.WEIGHT_BITS)
    np.testing.assert_array_equal(smoothing.smooth_signal(signal, sigma), expected)


def test_constant_stays_and_zero_is_the_signal_itself():
    signal = np.full((9, 12), 1234, dtype=np.int32)
    np.testing.assert_array_equal(smoothing.smooth_signal(signal, 1.7), signal)
    assert smoothing.smooth_signal(signal, 0) is signal


def test_match_with_and_without_smoothing():
    rng = np.random.default_rng(4)
    right = rng.integers(0, 256, (40, 90), dtype=np.uint8)
    left = np.roll(right, 3, axis=1)
    plain = dcstereo.match(left, right, max_disparity=8)
    zero = dcstereo.match(left, right, max_disparity=8, census_smoothing=0.0)
    assert zero.disparity.tobytes() == plain.disparity.tobytes()  # 0: the default exactly
    smoothed = dcstereo.match(left, right, max_disparity=8, census_smoothing=1.2)
    assert np.nanmedian(smoothed.disparity[:, 12:]) == pytest.approx(3, abs=0.25)
    assert smoothed.disparity.tobytes() != plain.disparity.tobytes()
    assert smoothed.params.census_smoothing == 1.2


@pytest.mark.parametrize("value", [-0.5, 4.5, math.nan, math.inf, True, "1"])
def test_bad_values_are_refused_by_name(value):
    with pytest.raises(ValueError, match="census_smoothing"):
        MatchParams(max_disparity=8, census_smoothing=value)


def test_only_sgm_reads_it():
    with pytest.raises(ValueError, match="census_smoothing is read only by sgm"):
        MatchParams(max_disparity=8, method="dsi5", census_smoothing=1.0)


def test_cli_census_smoothing(pair):
    from dcstereo.cli import main

    folder, _ = pair
    runner, args = run_equals_match(folder, ["--census-smoothing", "1.2"], census_smoothing=1.2)
    bad = folder / "bad.pfm"
    result = runner.invoke(main, [*args, "-o", str(bad), "--census-smoothing", "-1"])
    assert result.exit_code != 0 and "census_smoothing must be from 0 to 4" in result.output
    assert "Traceback" not in result.output
    assert not bad.exists()


@pytest.mark.slow
@pytest.mark.dataset
@pytest.mark.parametrize(
    ("options", "pinned"),
    [
        # sgm alone: 9.584 without the smoothing
        ({}, 4.694),
        # with the three stages: 5.602 without it
        ({"photometric": "matched", "planes": True, "median": "weighted"}, 3.477),
    ],
)
def test_smoothing_keeps_its_measured_d1_outdoors(options, pinned):
    d1 = kitti_d1("kitti2012_000090_10", census_smoothing=1.2, **options)
    assert d1 <= pinned + 0.01, f"D1 {d1:.3f} % > {pinned}"
