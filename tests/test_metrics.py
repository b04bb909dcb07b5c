import math

import numpy as np
import pytest

from dcstereo.evaluation.metrics import (
    bad_pixel_rate,
    density,
    evaluate,
    mean_abs_error,
    rms_error,
)

NAN = np.nan

# A 2x4 case computed on paper.
TRUTH = np.array([[1.0, 2.0, 3.0, NAN], [5.0, 6.0, 7.0, 8.0]])
ESTIMATE = np.array([[1.0, 3.0, 5.5, 0.0], [NAN, 6.5, 7.0, 4.0]])
# errors:          [[0,   1,   2.5, -- ], [NaN, 0.5, 0,   4  ]]   (truth NaN: not scored)
MASK = np.array([[True, True, True, True], [False, True, True, True]])


def test_bad_pixel_rate_by_hand():
    # 7 scored; errors 0, 1, 2.5, NaN, 0.5, 0, 4 -> > 1: 2.5, NaN, 4.
    assert bad_pixel_rate(ESTIMATE, TRUTH) == pytest.approx(100 * 3 / 7)
    # > 0.5: 1, 2.5, NaN, 4.
    assert bad_pixel_rate(ESTIMATE, TRUTH, threshold=0.5) == pytest.approx(100 * 4 / 7)
    assert bad_pixel_rate(ESTIMATE, TRUTH, threshold=4.0) == pytest.approx(100 * 1 / 7)


def test_bad_pixel_rate_threshold_is_strict():
    truth = np.array([0.0, 0.0, 0.0])
    estimate = np.array([1.0, -1.0, 1.0000001])
    assert bad_pixel_rate(estimate, truth, threshold=1.0) == pytest.approx(100 / 3)
    assert bad_pixel_rate(estimate, truth, threshold=0.0) == 100.0


def test_bad_pixel_rate_mask_and_unknown_truth():
    # Mask drops the NaN estimate at (1, 0); truth NaN drops (0, 3): 6 scored, bad 2.5 and 4.
    assert bad_pixel_rate(ESTIMATE, TRUTH, mask=MASK) == pytest.approx(100 * 2 / 6)


def test_non_finite_estimate_counts_as_bad():
    truth = np.array([1.0, 1.0, 1.0, 1.0])
    estimate = np.array([1.0, NAN, np.inf, -np.inf])
    assert bad_pixel_rate(estimate, truth) == 75.0
    assert density(estimate, truth) == 25.0
    assert mean_abs_error(estimate, truth) == 0.0


def test_mae_rms_density_by_hand():
    # Finite errors among scored: 0, 1, 2.5, 0.5, 0, 4 (the NaN estimate is left out).
    errors = np.array([0.0, 1.0, 2.5, 0.5, 0.0, 4.0])
    assert mean_abs_error(ESTIMATE, TRUTH) == pytest.approx(errors.mean())
    assert rms_error(ESTIMATE, TRUTH) == pytest.approx(math.sqrt(np.mean(errors**2)))
    assert density(ESTIMATE, TRUTH) == pytest.approx(100 * 6 / 7)
    assert density(ESTIMATE, TRUTH, mask=MASK) == 100.0
    assert mean_abs_error(ESTIMATE, TRUTH, mask=MASK) == pytest.approx(8.0 / 6)


def test_signed_errors_do_not_cancel():
    truth = np.zeros(4)
    estimate = np.array([2.0, -2.0, 2.0, -2.0])
    assert mean_abs_error(estimate, truth) == 2.0
    assert rms_error(estimate, truth) == 2.0


def test_no_finite_estimate_gives_nan():
    truth = np.array([1.0, 2.0])
    estimate = np.array([NAN, NAN])
    assert math.isnan(mean_abs_error(estimate, truth))
    assert math.isnan(rms_error(estimate, truth))
    assert density(estimate, truth) == 0.0
    assert bad_pixel_rate(estimate, truth) == 100.0


def test_truth_against_itself_is_perfect():
    rng = np.random.default_rng(1234)
    truth = rng.uniform(0, 60, (30, 40)).astype(np.float32)
    truth[rng.random(truth.shape) < 0.2] = NAN
    for threshold in (0.0, 0.5, 1.0):
        assert bad_pixel_rate(truth, truth, threshold=threshold) == 0.0
    assert mean_abs_error(truth, truth) == 0.0
    assert rms_error(truth, truth) == 0.0
    assert density(truth, truth) == 100.0


def test_integer_inputs_and_dtypes():
    truth = np.array([[10, 20]], dtype=np.uint8)
    estimate = np.array([[12, 20]], dtype=np.uint8)  # no wrap-around in the difference
    assert bad_pixel_rate(estimate, truth) == 50.0
    assert mean_abs_error(estimate, truth) == 1.0


def test_evaluate_matches_the_single_metrics():
    masks = {"all": np.ones(TRUTH.shape, bool), "part": MASK}
    scores = evaluate(ESTIMATE, TRUTH, masks)
    assert list(scores) == ["all", "part"]
    keys = {"bad-0.5", "bad-1.0", "bad-2.0", "bad-4.0", "mae", "rms", "density"}
    assert set(scores["all"]) == keys
    for name, mask in masks.items():
        row = scores[name]
        for t in (0.5, 1.0, 2.0, 4.0):
            assert row[f"bad-{t}"] == bad_pixel_rate(ESTIMATE, TRUTH, mask=mask, threshold=t)
        assert row["mae"] == pytest.approx(mean_abs_error(ESTIMATE, TRUTH, mask=mask))
        assert row["rms"] == pytest.approx(rms_error(ESTIMATE, TRUTH, mask=mask))
        assert row["density"] == density(ESTIMATE, TRUTH, mask=mask)
        assert all(isinstance(v, float) for v in row.values())


def test_evaluate_custom_thresholds_and_nan_rows():
    truth = np.array([1.0, 2.0])
    scores = evaluate(np.array([NAN, NAN]), truth, {"all": np.ones(2, bool)}, thresholds=(3,))
    assert scores["all"]["bad-3.0"] == 100.0
    assert math.isnan(scores["all"]["mae"]) and math.isnan(scores["all"]["rms"])
    assert scores["all"]["density"] == 0.0


def test_shape_mismatch_names_both_shapes():
    with pytest.raises(ValueError, match=r"\(2, 3\).*\(3, 2\)"):
        bad_pixel_rate(np.zeros((2, 3)), np.zeros((3, 2)))
    with pytest.raises(ValueError, match=r"mask \(2, 2\).*truth \(2, 3\)"):
        density(np.zeros((2, 3)), np.zeros((2, 3)), mask=np.ones((2, 2), bool))


@pytest.mark.parametrize("metric", [bad_pixel_rate, mean_abs_error, rms_error, density])
def test_no_scored_pixel_raises(metric):
    truth = np.array([1.0, NAN])
    with pytest.raises(ValueError, match="no pixel is scored"):
        metric(np.zeros(2), truth, mask=np.array([False, True]))
    with pytest.raises(ValueError, match="no pixel is scored"):
        metric(np.zeros(0), np.zeros(0))


def test_evaluate_names_the_empty_mask():
    with pytest.raises(ValueError, match="mask 'disc'"):
        evaluate(np.zeros(2), np.ones(2), {"all": np.ones(2, bool), "disc": np.zeros(2, bool)})


def test_bad_threshold_and_mask_types():
    with pytest.raises(ValueError, match="threshold"):
        bad_pixel_rate(np.zeros(2), np.zeros(2), threshold=-1.0)
    with pytest.raises(ValueError, match="threshold"):
        bad_pixel_rate(np.zeros(2), np.zeros(2), threshold=NAN)
    with pytest.raises(TypeError, match="mask must be a boolean array"):
        bad_pixel_rate(np.zeros(2), np.zeros(2), mask=np.array([255, 0], np.uint8))
    with pytest.raises(TypeError, match="estimate must be an array of real numbers"):
        bad_pixel_rate(np.array(["a", "b"]), np.zeros(2))
