"""Section 2, divide and conquer: the reliability tests, the ordering, the anchors, and dc.

The anchored DP inside a rectangle is checked against the naive oracle in test_kernels.py.
"""

import math
from fractions import Fraction

import numpy as np
import pytest

import dcstereo
import naive_divide
import synthetic
from dcstereo import FLAG_FEATURE
from dcstereo.costs import window as costs
from dcstereo.divide import features
from dcstereo.evaluation.datasets import load_middlebury
from dcstereo.evaluation.metrics import bad_pixel_rate
from dcstereo.params import DEFAULT_DC_SLANT_COST, MatchParams
from dcstereo.signal import SIGNAL_STEPS, matching_signal
from naive_divide import window_variance

#: bad-1.0 nonocc (%) of the DP entry of the Middlebury taxonomy, which dc must reach.
MIDDLEBURY_TARGETS = {"tsukuba": 4.12, "venus": 10.1, "teddy": 14.0, "cones": 10.5}

PAPER_TESTS_ONLY = {"lr_check": False, "uniqueness": 0.0, "edge_guard": 0}


# --------------------------------------------------------------------------- helpers


def naive_pair_statistics(left, right, y, x, j, window):
    """Window variances and SSD of the pair (y, x) <-> (y, j), straight from eq. 2 and 3."""
    radius = window // 2
    pad = ((radius, radius), (radius, radius))
    left_i = np.pad(matching_signal(left) / SIGNAL_STEPS, pad, mode="edge")
    right_i = np.pad(matching_signal(right) / SIGNAL_STEPS, pad, mode="edge")
    win_l = left_i[y : y + window, x : x + window]
    win_r = right_i[y : y + window, j : j + window]
    return win_l.var(), win_r.var(), float(((win_l - win_r) ** 2).sum())


def flat_background_pair(rng, height, width, background, foreground, columns, level=100):
    """A randomly textured strip in front of a perfectly flat background.

    Returns ``(left, right, truth)``; truth is NaN where the left pixel has no partner.
    The background pixels next to the strip see its texture in their window: the classic
    case where a window match fattens the foreground.
    """
    x0, x1 = columns
    front = synthetic.texture(rng, height, width)
    right = np.full((height, width), level, dtype=np.uint8)
    right[:, x0 - foreground : x1 - foreground] = front[:, x0 - foreground : x1 - foreground]
    left = np.full((height, width), level, dtype=np.uint8)
    truth = np.full((height, width), float(background), dtype=np.float32)
    for x in range(width):
        if x0 <= x < x1:
            left[:, x] = front[:, x - foreground]
            truth[:, x] = foreground
        else:
            j = x - background
            if j < 0 or x0 - foreground <= j < x1 - foreground:
                truth[:, x] = np.nan
    return left, right, truth


def feature_truth(result, truth):
    rows = result.features[:, 0].astype(np.int64)
    cols = result.features[:, 1].astype(np.int64)
    return truth[rows, cols]


# --------------------------------------------------------------------------- SER and VS


def test_ser_and_vs_hand_computed_on_a_3x3_window():
    # Left window 1..9 (gray levels), the right one the same with 6 instead of 5 at the
    # centre. var_L = 285/9 - 25 = 20/3; var_R = 296/9 - (46/9)^2 = 548/81; SSD = 1.
    # SER = (20/3 + 548/81) / 1 = 1088/81; VS = |540 - 548| / 81 = 8/81, or 8/1088 relative.
    window_l = np.arange(1, 10).reshape(3, 3)
    window_r = window_l.copy()
    window_r[1, 1] = 6
    # one row of three pixels padded by one column each side; the windows sit at x = j = 1
    left_p = np.zeros((3, 5), dtype=np.int32)
    right_p = np.zeros((3, 5), dtype=np.int32)
    left_p[:, 1:4] = window_l * SIGNAL_STEPS
    right_p[:, 1:4] = window_r * SIGNAL_STEPS
    colsum = np.empty(5, dtype=np.int64)
    colsq = np.empty(5, dtype=np.int64)
    var_row = np.empty(3)
    features.window_variance_row(left_p, 0, 1, SIGNAL_STEPS, colsum, colsq, var_row, False)
    var_l = var_row[1]
    var_r = naive_divide.pixel_variance(right_p, 0, 1, 1, SIGNAL_STEPS)
    ssd = features.window_ssd(left_p, right_p, 0, 1, 1, 1) / SIGNAL_STEPS**2
    assert var_l == pytest.approx(float(Fraction(20, 3)), rel=1e-12)
    assert var_r == pytest.approx(float(Fraction(548, 81)), rel=1e-12)
    assert ssd == 1.0
    ser, vs = features.reliability(var_l, var_r, ssd, False)
    assert ser == pytest.approx(float(Fraction(1088, 81)), rel=1e-12)
    assert vs == pytest.approx(float(Fraction(8, 81)), rel=1e-12)
    _, vs_relative = features.reliability(var_l, var_r, ssd, True)
    assert vs_relative == pytest.approx(float(Fraction(8, 1088)), rel=1e-12)


def test_reliability_of_a_perfect_match_and_of_flat_windows():
    assert features.reliability(3.0, 5.0, 0.0, True) == (math.inf, 0.25)
    assert features.reliability(0.0, 0.0, 0.0, True) == (math.inf, 0.0)
    assert features.reliability(0.0, 0.0, 2.0, False) == (0.0, 0.0)


@pytest.mark.parametrize("radius", [0, 1, 2])
def test_window_variance_row_matches_the_numpy_variance(radius):
    rng = np.random.default_rng(5)
    height, width = 7, 13
    signal = rng.integers(0, 4081, size=(height, width)).astype(np.int32)
    padded = np.pad(signal, radius, mode="edge")
    expected = window_variance(signal / SIGNAL_STEPS, 2 * radius + 1)
    colsum = np.empty(width + 2 * radius, dtype=np.int64)
    colsq = np.empty(width + 2 * radius, dtype=np.int64)
    out = np.empty(width)
    colsum_run = np.empty_like(colsum)
    colsq_run = np.empty_like(colsq)
    out_run = np.empty(width)
    for y in range(height):
        features.window_variance_row(padded, y, radius, SIGNAL_STEPS, colsum, colsq, out, False)
        np.testing.assert_allclose(out, expected[y], rtol=1e-9, atol=1e-9)
        for x in range(width):
            assert naive_divide.pixel_variance(padded, y, x, radius, SIGNAL_STEPS) == out[x]
        # the running sums, updated row by row, give the very same values
        features.window_variance_row(
            padded, y, radius, SIGNAL_STEPS, colsum_run, colsq_run, out_run, y > 0
        )
        np.testing.assert_array_equal(out_run, out)


@pytest.mark.parametrize("radius", [0, 1, 2])
def test_window_ssd_matches_a_plain_sum_over_the_truncated_window(radius):
    # every cell, interior (exact integer path) and near the edges (truncated, rescaled)
    rng = np.random.default_rng(17 + radius)
    height, width = 5, 9
    left = rng.integers(0, 4081, size=(height, width)).astype(np.int32)
    right = rng.integers(0, 4081, size=(height, width)).astype(np.int32)
    left_p = np.pad(left, radius, mode="edge")
    right_p = np.pad(right, radius, mode="edge")
    win = 2 * radius + 1
    for y in range(height):
        for x in range(width):
            for j in range(width):
                cols = [
                    c
                    for c in range(-radius, radius + 1)
                    if 0 <= x + c < width and 0 <= j + c < width
                ]
                diff = (
                    left_p[y : y + win, [x + c + radius for c in cols]].astype(np.int64)
                    - right_p[y : y + win, [j + c + radius for c in cols]]
                )
                expected = float(np.sum(diff * diff)) * win / len(cols)
                got = features.window_ssd(left_p, right_p, y, x, j, radius)
                assert got == pytest.approx(expected, rel=1e-12)


def test_uniqueness_ratio_hand_computed():
    cost = np.array([[5.0, 1.0, 2.0, 6.0, 3.0]])
    # the neighbours 0 and 2 of the best (k = 1) are left out: second = min(6, 3) = 3
    assert features.uniqueness_ratio(cost, 0, 1) == 3.0
    # measured at a cost that is not the least: the ratio falls below 1
    assert features.uniqueness_ratio(cost, 0, 4) == pytest.approx(1.0 / 3.0)
    # a perfect match: infinitely unique unless another perfect match lies two away
    assert features.uniqueness_ratio(np.array([[0.0, 4.0, 4.0]]), 0, 0) == math.inf
    assert features.uniqueness_ratio(np.array([[0.0, 7.0, 0.0]]), 0, 0) == 1.0
    # a band of two: no disparity is two away, so the best is unique
    assert features.uniqueness_ratio(np.array([[2.0, 1.0]]), 0, 1) == math.inf


def test_block_match_is_computed_once_per_pixel():
    cost = np.array([[4.0, 2.0, 9.0, 8.0], [np.inf, np.inf, np.inf, np.inf]])
    wta_k = np.full(2, features.NOT_MATCHED, dtype=np.int64)
    wta_ratio = np.zeros(2)
    assert features.block_match(cost, 0, wta_k, wta_ratio) == 1
    assert wta_ratio[0] == 4.0  # k = 3 (cost 8) is the only one two away from k = 1
    assert features.block_match(cost, 1, wta_k, wta_ratio) == -1  # empty band
    cost[0, 3] = 0.0  # cached: a later change of the cost is not seen
    assert features.block_match(cost, 0, wta_k, wta_ratio) == 1


@pytest.mark.parametrize("seed", range(3))
def test_features_carry_the_ser_and_vs_of_eq_2_and_3(seed):
    rng = np.random.default_rng(300 + seed)
    left, right, _ = synthetic.slanted_pair(rng, 12, 60, 3, 0.1)
    result = dcstereo.match(left, right, max_disparity=8, window=5, method="dc", **PAPER_TESTS_ONLY)
    assert len(result.features) > 0
    for row, x, j, ser, vs in result.features:
        var_l, var_r, ssd = naive_pair_statistics(left, right, int(row), int(x), int(j), 5)
        expected_ser = (var_l + var_r) / ssd if ssd > 0 else math.inf
        assert ser == pytest.approx(expected_ser, rel=1e-5)
        assert vs == pytest.approx(abs(var_l - var_r) / (var_l + var_r), rel=1e-5, abs=1e-7)
        assert ser >= result.params.ser_min and vs <= result.params.vs_max


# --------------------------------------------------------------------------- the search, naive twin

SEARCH_OPTIONS = [
    {},
    PAPER_TESTS_ONLY,
    {"max_candidates": 2, "lr_check": True},
    {"max_candidates": 1, "uniqueness": 0.0},
    {"uniqueness": 0.0, "lr_check": True},
    {"lr_check": True},
    {"vs_relative": False, "vs_max": 400.0, "ser_min": 2.0},
    {"edge_guard": 0, "uniqueness": 1.2, "feature_floor": 20.0},
]


def search_pairs_for_comparison():
    rng = np.random.default_rng(77)
    left, right, _ = synthetic.object_pair(rng, 6, 48, 2, 7, (15, 30))
    yield left, right, 9, 0
    left, right, _ = synthetic.slanted_pair(rng, 5, 40, 2, 0.15)
    yield left, right, 8, -2
    # noisy copies: many candidates fail some test, in many intervals
    left = np.clip(left.astype(int) + rng.integers(-40, 41, left.shape), 0, 255).astype(np.uint8)
    yield left, right, 8, 0
    yield synthetic.texture(rng, 5, 36), synthetic.texture(rng, 5, 36), 6, 0
    # a stretched strip: neighbouring left pixels show the same right pixel, so the
    # left-right test has rivals to find
    right = synthetic.texture(rng, 5, 40)
    source = [max(x - 3, 0) for x in range(16)] + [13 + (x - 16) // 2 for x in range(16, 28)]
    source += [x - 9 for x in range(28, 40)]
    yield right[:, source], right, 10, 0
    # a periodic texture (period 5): without the uniqueness test, pixels a period apart
    # are exact rivals for the same right pixel, which the left-right test refuses
    right = np.tile(synthetic.texture(rng, 5, 5), (1, 8))
    left = np.empty_like(right)
    left[:, 2:] = right[:, :-2]
    left[:, :2] = synthetic.texture(rng, 5, 2)
    yield left, right, 9, 0


@pytest.mark.parametrize("options", SEARCH_OPTIONS, ids=lambda o: ",".join(o) or "defaults")
def test_feature_search_agrees_with_the_naive_twin(options):
    # the kernel's accepted pairs (its up-front tests with the uniqueness test and no limit
    # on the tries, the per-interval tests otherwise) against plain recursion
    total_pairs = 0
    radius = 2
    for left, right, max_disparity, min_disparity in search_pairs_for_comparison():
        params = MatchParams(
            max_disparity=max_disparity,
            min_disparity=min_disparity,
            window=5,
            method="dc",
            **options,
        )
        result = dcstereo.match(
            left,
            right,
            max_disparity=max_disparity,
            min_disparity=min_disparity,
            window=5,
            method="dc",
            **options,
        )
        left_p = np.pad(matching_signal(left), radius, mode="edge")
        right_p = np.pad(matching_signal(right), radius, mode="edge")
        height, width = left.shape
        ndisp = params.num_disparities
        cost = np.empty((width, ndisp))
        vcol = np.empty((width, ndisp), dtype=np.int32)
        colsum = np.empty(width + 2 * radius, dtype=np.int64)
        colsq = np.empty_like(colsum)
        for y in range(height):
            costs.row_costs(left_p, right_p, y, min_disparity, ndisp, radius, vcol, cost, False)
            var_l = np.empty(width)
            var_r = np.empty(width)
            for signal, out in ((left_p, var_l), (right_p, var_r)):
                features.window_variance_row(
                    signal, y, radius, SIGNAL_STEPS, colsum, colsq, out, False
                )

            def ssd_of(p, j, y=y, left_p=left_p, right_p=right_p):
                return features.window_ssd(left_p, right_p, y, p, j, radius) / SIGNAL_STEPS**2

            expected = naive_divide.divide_pairs(
                cost,
                ssd_of,
                var_l,
                var_r,
                dmin=min_disparity,
                radius=radius,
                ser_min=params.ser_min,
                vs_max=params.vs_max,
                vs_relative=params.vs_relative,
                var_floor=params.feature_floor,
                max_candidates=params.max_candidates,
                lr_check=params.lr_check,
                uniqueness=params.uniqueness,
                edge_guard=params.effective_edge_guard,
            )
            got = result.features[result.features[:, 0] == y]
            assert [int(x) for x in got[:, 1]] == sorted(expected), (options, y)
            for _, x, j, ser, vs in got:
                exp_j, exp_ser, exp_vs = expected[int(x)]
                assert int(j) == exp_j
                assert ser == pytest.approx(exp_ser, rel=1e-6)  # float32 in the result
                assert vs == pytest.approx(exp_vs, rel=1e-6, abs=1e-7)
            total_pairs += len(expected)
    assert total_pairs > 10  # the cases do accept pairs


def test_up_front_tests_give_the_pairs_of_the_per_interval_search(middlebury_root):
    # with the uniqueness test and no limit on the tries, the search runs its interval-free
    # tests up front and picks candidates from a static table of range maxima (scanning the
    # interval when the table's choice is out of play); a limit too large to bite takes
    # the per-interval path with its segment tree: the pairs must be the same. Real scenes
    # have the left-right refusals and out-of-range matches that make the scans run.
    for scene in ("tsukuba", "cones"):
        data = load_middlebury(scene, root=middlebury_root.parent)
        left, right = data.left[100:140], data.right[100:140]
        up_front = dcstereo.match(left, right, max_disparity=data.max_disparity, method="dc")
        per_interval = dcstereo.match(
            left, right, max_disparity=data.max_disparity, max_candidates=10**6, method="dc"
        )
        assert len(up_front.features) > 500
        np.testing.assert_array_equal(up_front.features, per_interval.features)
        np.testing.assert_array_equal(up_front.disparity, per_interval.disparity)


# --------------------------------------------------------------------------- ordering, anchors


def scenes_for_properties():
    rng = np.random.default_rng(42)
    left, right, _ = synthetic.object_pair(rng, 16, 70, 2, 7, (25, 45))
    yield "object", left, right, 10
    left, right, _ = synthetic.slanted_pair(rng, 16, 70, 2, 0.15)
    yield "slanted", left, right, 14
    # unrelated views: whatever is accepted must still be ordered and pinned
    yield "noise", synthetic.texture(rng, 16, 70), synthetic.texture(rng, 16, 70), 12


@pytest.mark.parametrize("method", ["dc", "dc-linear"])
@pytest.mark.parametrize(
    "options",
    [{}, PAPER_TESTS_ONLY, {"lr_check": True}],
    ids=["defaults", "paper-tests", "lr-check"],
)
def test_accepted_pairs_are_strictly_ordered_and_the_path_passes_through_them(method, options):
    for name, left, right, max_disparity in scenes_for_properties():
        result = dcstereo.match(
            left, right, max_disparity=max_disparity, method=method, window=3, **options
        )
        features = result.features
        rows = features[:, 0].astype(np.int64)
        x_left = features[:, 1].astype(np.int64)
        x_right = features[:, 2].astype(np.int64)
        assert np.array_equal(features[:, 1], x_left) and np.array_equal(features[:, 2], x_right)
        for y in np.unique(rows):
            in_row = rows == y
            assert np.all(np.diff(x_left[in_row]) > 0), name
            assert np.all(np.diff(x_right[in_row]) > 0), name
        disparity = x_left - x_right
        assert np.all((disparity >= 0) & (disparity <= max_disparity)), name
        np.testing.assert_array_equal(result.disparity[rows, x_left], disparity, err_msg=name)
        flagged = (result.flags & FLAG_FEATURE) != 0
        assert flagged.sum() == len(features) and flagged[rows, x_left].all(), name
        # whole windows only, on both sides
        width = left.shape[1]
        assert np.all((x_left >= 1) & (x_left <= width - 2)), name
        assert np.all((x_right >= 1) & (x_right <= width - 2)), name


@pytest.mark.parametrize("slant_cost", [None, 0.0, 3.0])
@pytest.mark.parametrize("seed", range(3))
def test_dc_without_any_feature_is_dsi5(seed, slant_cost):
    rng = np.random.default_rng(400 + seed)
    left, right, _ = synthetic.object_pair(rng, 12, 50, 2, 6, (18, 32))
    nothing = {"feature_floor": 1e12}
    dc = dcstereo.match(left, right, max_disparity=8, method="dc", slant_cost=slant_cost, **nothing)
    same_slant = DEFAULT_DC_SLANT_COST if slant_cost is None else slant_cost
    dsi5 = dcstereo.match(left, right, max_disparity=8, method="dsi5", slant_cost=same_slant)
    assert len(dc.features) == 0
    np.testing.assert_array_equal(dc.disparity, dsi5.disparity)
    np.testing.assert_array_equal(dc.flags, dsi5.flags)
    np.testing.assert_array_equal(dc.path_cost, dsi5.path_cost)


# --------------------------------------------------------------------------- synthetic truth


@pytest.mark.parametrize(("seed", "disparity"), [(0, 3), (1, 5), (2, 9)])
def test_on_a_textured_constant_disparity_pair_every_feature_is_correct(seed, disparity):
    rng = np.random.default_rng(500 + seed)
    left, right = synthetic.constant_pair(rng, 16, 80, disparity)
    result = dcstereo.match(left, right, max_disparity=12, method="dc")
    features = result.features
    assert len(features) > 16 * 20  # dense: the texture is everywhere
    np.testing.assert_array_equal(features[:, 1] - features[:, 2], disparity)


@pytest.mark.parametrize("seed", range(3))
def test_on_an_object_over_a_textured_background_every_feature_is_correct(seed):
    rng = np.random.default_rng(600 + seed)
    left, right, truth = synthetic.object_pair(rng, 16, 90, 3, 9, (35, 60))
    result = dcstereo.match(left, right, max_disparity=12, method="dc")
    expected = feature_truth(result, truth)
    assert np.isfinite(expected).all()
    np.testing.assert_array_equal(result.features[:, 1] - result.features[:, 2], expected)


def test_the_guard_removes_the_pairs_that_fatten_a_foreground_strip():
    # Beside the strip the flat background windows see only the strip's texture, and SER
    # and VS alone accept them at the strip's disparity (and pin occluded pixels).
    rng = np.random.default_rng(700)
    left, right, truth = flat_background_pair(rng, 12, 80, 2, 8, (30, 50))
    paper = dcstereo.match(left, right, max_disparity=12, method="dc", **PAPER_TESTS_ONLY)
    paper_truth = feature_truth(paper, truth)
    paper_d = paper.features[:, 1] - paper.features[:, 2]
    assert not np.all(paper_d == paper_truth)  # wrong or occluded pairs were accepted
    guarded = dcstereo.match(left, right, max_disparity=12, method="dc")
    guarded_truth = feature_truth(guarded, truth)
    assert len(guarded.features) > 0
    np.testing.assert_array_equal(guarded.features[:, 1] - guarded.features[:, 2], guarded_truth)


# --------------------------------------------------------------------------- parameters


def test_slant_cost_default_is_the_methods_own():
    assert MatchParams(max_disparity=4, method="dc").effective_slant_cost == DEFAULT_DC_SLANT_COST
    assert MatchParams(max_disparity=4, method="dc-linear").effective_slant_cost == (
        DEFAULT_DC_SLANT_COST
    )
    assert MatchParams(max_disparity=4, method="dsi5").effective_slant_cost == 0.0
    assert MatchParams(max_disparity=4, method="dc", slant_cost=2).effective_slant_cost == 2.0
    rng = np.random.default_rng(800)
    left, right, _ = synthetic.object_pair(rng, 8, 40, 1, 5, (15, 25))
    default = dcstereo.match(left, right, max_disparity=6, method="dsi5")
    explicit = dcstereo.match(left, right, max_disparity=6, method="dsi5", slant_cost=0.0)
    np.testing.assert_array_equal(default.disparity, explicit.disparity)


def test_edge_guard_default_follows_the_window():
    assert MatchParams(max_disparity=4, method="dc").effective_edge_guard == 3
    assert MatchParams(max_disparity=4, window=9, method="dc").effective_edge_guard == 5
    assert MatchParams(max_disparity=4, edge_guard=0, method="dc").effective_edge_guard == 0
    assert MatchParams(max_disparity=4, edge_guard=2.0, method="dc").edge_guard == 2


@pytest.mark.parametrize(
    ("options", "error", "words"),
    [
        ({"edge_guard": -1}, ValueError, "edge_guard"),
        ({"edge_guard": 1.5}, TypeError, "edge_guard"),
        ({"edge_guard": True}, TypeError, "edge_guard"),
        ({"uniqueness": -1.0}, ValueError, "uniqueness"),
        ({"uniqueness": math.nan}, ValueError, "uniqueness"),
        ({"slant_cost": -2.0}, ValueError, "slant_cost"),
    ],
)
def test_bad_dc_parameters_are_named(options, error, words):
    with pytest.raises(error, match=words):
        MatchParams(max_disparity=4, method="dc", **options)


# --------------------------------------------------------------------------- Middlebury


@pytest.mark.dataset
@pytest.mark.slow
@pytest.mark.parametrize(("scene", "limit"), sorted(MIDDLEBURY_TARGETS.items()))
def test_dc_reaches_the_middlebury_dp_entry(middlebury_root, scene, limit):
    data = load_middlebury(scene, root=middlebury_root.parent)
    result = dcstereo.match(
        data.left, data.right, max_disparity=data.max_disparity, fill=True, method="dc"
    )
    bad = bad_pixel_rate(result.disparity, data.disparity, mask=data.masks["nonocc"])
    assert bad <= limit, f"{scene}: bad-1.0 nonocc {bad:.2f}% > {limit}%"


@pytest.mark.parametrize("method", ["dc", "dc-linear"])
def test_a_4000_pixel_scanline_is_split_thousands_of_times_without_recursion(method):
    # a textured row gives a reliable pair every few pixels: the work list holds
    # thousands of intervals at once (a recursive driver would nest as deep)
    rng = np.random.default_rng(4000)
    left, right = synthetic.constant_pair(rng, 5, 4000, 6)
    result = dcstereo.match(left, right, max_disparity=10, method=method)
    per_row = np.bincount(result.features[:, 0].astype(np.int64), minlength=5)
    assert per_row.min() > 1000
    np.testing.assert_array_equal(result.features[:, 1] - result.features[:, 2], 6)
    inside = result.disparity[:, 10:-10]
    assert np.count_nonzero(inside != 6) <= 0.001 * inside.size


@pytest.mark.parametrize("seed", range(5))
def test_candidate_tree_gives_the_strongest_leftmost_candidate_of_any_interval(seed):
    # the segment tree of divide_row against a plain scan, through sets and queries
    rng = np.random.default_rng(900 + seed)
    width = int(rng.integers(1, 40))
    values = np.where(rng.random(width) < 0.3, -np.inf, rng.integers(0, 6, width).astype(float))
    size = 1
    while size < width:
        size *= 2
    tree_v = np.full(2 * size, -np.inf)
    tree_i = np.full(2 * size, -1, dtype=np.int64)
    for p in range(width):
        features._tree_set(tree_v, tree_i, size, p, values[p])
        tree_i[size + p] = p
    for node in range(size - 1, 0, -1):
        features._tree_pull(tree_v, tree_i, node)
    for _ in range(60):
        if rng.random() < 0.4:
            p = int(rng.integers(0, width))
            values[p] = -np.inf if rng.random() < 0.5 else float(rng.integers(0, 6))
            features._tree_set(tree_v, tree_i, size, p, values[p])
        lo = int(rng.integers(0, width))
        hi = int(rng.integers(lo - 1, width))
        window = values[lo : hi + 1]
        if window.size == 0 or not np.isfinite(window).any():
            expected = -1
        else:
            expected = lo + int(np.argmax(window))  # argmax: the first of equal maxima
        assert features._tree_best(tree_v, tree_i, size, lo, hi) == expected
