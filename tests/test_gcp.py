"""``dsi3-gcp``: selection of the ground control points, the path through them, the CLI."""

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import dcstereo
import naive_gcp_bt
import synthetic
from dcstereo import io
from dcstereo.cli import main
from dcstereo.divide import gcp
from dcstereo.result import FLAG_FEATURE


def kernel_select(cost, var_l, dmin, radius, uniqueness, var_floor):
    width = cost.shape[0]
    gcp_x = np.empty(width, dtype=np.int64)
    gcp_j = np.empty(width, dtype=np.int64)
    n = gcp.select_gcps(cost, var_l, dmin, radius, uniqueness, var_floor, gcp_x, gcp_j)
    return list(zip(gcp_x[:n].tolist(), gcp_j[:n].tolist(), strict=True))


def random_costs(rng, width, dmin, ndisp, high):
    cost = rng.integers(0, high, size=(width, ndisp)).astype(np.float64)
    for x in range(width):
        for k in range(ndisp):
            if not 0 <= x - dmin - k < width:
                cost[x, k] = np.inf
    return cost


def random_selection_case(seed):
    """A tiny random GCP selection problem: (cost, var_l, dmin, radius, uniqueness, floor)."""
    rng = np.random.default_rng(500 + seed)
    width = int(rng.integers(6, 13))
    ndisp = int(rng.integers(2, 6))
    dmin = int(rng.integers(-2, 2))
    radius = int(rng.integers(0, 2))
    # a few cost levels: ties, failed ratio tests and crossing candidates all occur
    cost = random_costs(rng, width, dmin, ndisp, int(rng.integers(3, 30)))
    var_l = rng.uniform(0, 10, size=width)
    uniqueness = float(rng.choice([0.0, 1.0, 1.5, 2.0]))
    var_floor = float(rng.choice([0.0, 3.0]))
    return cost, var_l, dmin, radius, uniqueness, var_floor


@pytest.mark.parametrize("seed", range(40))
def test_gcp_selection_matches_brute_force(seed):
    case = random_selection_case(seed)
    kept, _ = naive_gcp_bt.select_gcps(*case)
    assert kernel_select(*case) == kept


def test_brute_force_cases_include_crossing_candidates():
    # the ordering step matters in the random cases above: some drop a candidate
    dropped = 0
    for seed in range(40):
        kept, found = naive_gcp_bt.select_gcps(*random_selection_case(seed))
        dropped += len(found) > len(kept)
    assert dropped >= 3


@pytest.mark.parametrize("kernels", [gcp])
@pytest.mark.parametrize("m", [0, 1, 2, 7, 60, 2500])
def test_run_lengths_are_the_longest_increasing_runs_from_each_candidate(kernels, m):
    # the O(m log m) lengths against their definition: 1 + the longest from a later
    # candidate of larger j (m = 2500: a wide textured row's candidates)
    rng = np.random.default_rng(m)
    for values in (rng.permutation(3 * m)[:m], rng.integers(0, max(m // 3, 1), m), np.arange(m)):
        cand_j = values.astype(np.int64)
        length = np.zeros(m, dtype=np.int64)
        longest = kernels._run_lengths(cand_j, m, length, np.empty(m, dtype=np.int64))
        expected = np.zeros(m, dtype=np.int64)
        for i in range(m - 1, -1, -1):
            later = expected[i + 1 :][cand_j[i + 1 :] > cand_j[i]]
            expected[i] = 1 + (later.max() if len(later) else 0)
        np.testing.assert_array_equal(length, expected)
        assert longest == (expected.max() if m else 0)


def test_gcp_selection_by_hand():
    # 6 pixels, disparities 0..2, radius 0, no ratio or variance test; x=3 <-> 3 and
    # x=4 <-> 2 cross, so only one of them can be kept.
    inf = np.inf
    cost = np.array(
        [
            [1, inf, inf],  # x=0: j=0
            [9, 0, inf],  # x=1: j=0 (d=1)
            [9, 9, 9],  # x=2: no unique match (first of ties: d=0, j=2, loses LR to x=4)
            [0, 9, 9],  # x=3: j=3
            [9, 9, 0],  # x=4: j=2 (crosses x=3)
            [9, 0, 9],  # x=5: j=4
        ]
    )
    var_l = np.ones(6)
    kept, found = naive_gcp_bt.select_gcps(cost, var_l, 0, 0, 0.0, 0.0)
    # x=0 <-> 0 loses the left-right check to x=1 (cost 0 < 1); x=2 <-> 2 to x=4
    assert found == [(1, 0), (3, 3), (4, 2), (5, 4)]
    # longest increasing: (1,0),(3,3),(5,4) and (1,0),(4,2),(5,4); the first is kept
    assert kept == [(1, 0), (3, 3), (5, 4)]
    assert kernel_select(cost, var_l, 0, 0, 0.0, 0.0) == kept


@pytest.fixture(scope="module")
def object_scene():
    rng = np.random.default_rng(61)
    left, right, truth = synthetic.object_pair(rng, 30, 90, 2, 9, (30, 60))
    return left, right, truth


@pytest.mark.parametrize("cost", ["sad", "bt"])
def test_gcp_path_passes_through_every_control_point(object_scene, cost):
    left, right, truth = object_scene
    result = dcstereo.match(left, right, max_disparity=12, method="dsi3-gcp", cost=cost)
    features = result.features
    assert features is not None and len(features) > 5 * left.shape[0]
    assert np.all(np.isnan(features[:, 3:]))
    rows = features[:, 0].astype(int)
    xl = features[:, 1].astype(int)
    xr = features[:, 2].astype(int)
    np.testing.assert_array_equal(result.disparity[rows, xl], xl - xr)
    assert np.all(result.flags[rows, xl] & FLAG_FEATURE)
    assert np.count_nonzero(result.flags & FLAG_FEATURE) == len(features)
    for y in np.unique(rows):
        mine = rows == y
        assert np.all(np.diff(xl[mine]) > 0) and np.all(np.diff(xr[mine]) > 0)
    scored = np.isfinite(truth) & np.isfinite(result.disparity)
    assert np.mean(result.disparity[scored] == truth[scored]) > 0.95


def test_gcp_without_control_points_is_dsi3(object_scene):
    left, right, _ = object_scene
    for cost in ("sad", "bt"):
        plain = dcstereo.match(left, right, max_disparity=12, method="dsi3", cost=cost)
        none = dcstereo.match(
            left, right, max_disparity=12, method="dsi3-gcp", cost=cost, gcp_variance_floor=1e30
        )
        assert none.features.shape == (0, 5)
        np.testing.assert_array_equal(none.disparity, plain.disparity)
        np.testing.assert_array_equal(none.flags, plain.flags)
        np.testing.assert_array_equal(none.path_cost, plain.path_cost)


def test_gcp_path_costs_at_least_the_free_dsi3_path(object_scene):
    # forcing the path through points can only make the optimum dearer
    left, right, _ = object_scene
    free = dcstereo.match(left, right, max_disparity=12, method="dsi3", occlusion_cost=3)
    forced = dcstereo.match(left, right, max_disparity=12, method="dsi3-gcp", occlusion_cost=3)
    assert np.all(forced.path_cost >= free.path_cost)
    assert np.all(np.isfinite(forced.path_cost))


@pytest.mark.parametrize(
    ("name", "value"),
    [("gcp_uniqueness", -1.0), ("gcp_variance_floor", float("nan")), ("gcp_uniqueness", "2")],
)
def test_bad_gcp_parameters_are_value_errors(name, value):
    left = np.zeros((8, 16), dtype=np.uint8)
    with pytest.raises(ValueError, match=name):
        dcstereo.match(left, left, max_disparity=2, method="dsi3-gcp", **{name: value})


def test_cli_writes_the_control_points(tmp_path, object_scene):
    left, right, _ = object_scene
    Image.fromarray(left).save(tmp_path / "left.png")
    Image.fromarray(right).save(tmp_path / "right.png")
    args = [
        "run",
        tmp_path / "left.png",
        tmp_path / "right.png",
        "-o",
        tmp_path / "d.pfm",
        "--max-disparity",
        12,
        "--method",
        "dsi3-gcp",
        "--features-out",
        tmp_path / "f.csv",
    ]
    result = CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    features = io.read_features_csv(tmp_path / "f.csv")
    disparity = io.read_disparity(tmp_path / "d.pfm")
    rows, xl, xr = features[:, 0].astype(int), features[:, 1].astype(int), features[:, 2]
    assert len(features) > 0
    np.testing.assert_array_equal(disparity[rows, xl], xl - xr)
