"""The ``redert`` method: kernels against ``naive_redert.py``, synthetic scenes, errors."""

import math

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import dcstereo
import naive_redert
import synthetic
from dcstereo import MatchParams
from dcstereo import _records as records
from dcstereo.evaluation.metrics import bad_pixel_rate, mean_abs_error
from dcstereo.methods.redert import match_redert, orientation_steps
from dcstereo.scanline import redert


def run_dp(node, seg, dmin, oq, occ, orient, slant, steps=4, discount=0.0, run_cap=1, ring=None):
    """Call ``scanline_dp``; return (total, path) in the oracle's format.

    ``ring``: the columns its table keeps (default: every column).
    """
    width, ndisp, norient = node.shape
    nstates = norient + 2 * run_cap + 2
    work = records.RedertScratch(
        np.empty((width if ring is None else ring, ndisp, nstates)),
        np.empty((width, ndisp, nstates), dtype=np.uint8),
        np.empty(2 * width + 2, dtype=np.int64),
        np.empty(2 * width + 2, dtype=np.int64),
        np.empty(2 * width + 2, dtype=np.int64),
    )
    model = records.redert_model(steps, oq, occ, discount, run_cap, orient, slant)
    n, total = redert.scanline_dp(node, seg, dmin, model, work)
    path_x, path_k, path_st = work.path_x, work.path_k, work.path_st
    if n == 0:
        return math.inf, []
    # kernel states: matched, left run counts 1..N, right run counts 1..N, border runs
    occluded = [("l", c) for c in range(1, run_cap + 1)] + [("r", c) for c in range(1, run_cap + 1)]
    occluded += [naive_redert.LEFT_BORDER, naive_redert.RIGHT_BORDER]
    path = []
    for x, k, st in zip(path_x[:n][::-1], path_k[:n][::-1], path_st[:n][::-1], strict=True):
        x, k, st = int(x), int(k), int(st)
        state = ("m", st) if st < norient else occluded[st - norient]
        path.append(((x, x - dmin - k), state))
    # the virtual start the first node came from: a diagonal match or an occlusion
    (i, j), state = path[0]
    left_first = state[0] in ("l", "lb")
    right_first = state[0] in ("r", "rb")
    start = (i - 1, j) if left_first else (i, j - 1) if right_first else (i - 1, j - 1)
    return total, [(start, naive_redert.START)] + path


def random_costs(rng, width, dmin, ndisp, oq, steps=4):
    """Random integer node costs and segment costs (inf where the kernels put inf)."""
    norient = len(oq)
    node = rng.integers(0, 20, size=(width, ndisp, norient)).astype(np.float64)
    seg = np.full_like(node, np.inf)
    for x in range(width):
        for k in range(ndisp):
            d = dmin + k
            if not 0 <= x - d < width:
                node[x, k] = np.inf
                continue
            for o, q in enumerate(oq):
                length, delta = naive_redert.segment(q, steps)
                if x - length >= 0 and 0 <= x - length - (d - delta) and 0 <= k - delta < ndisp:
                    seg[x, k, o] = node[x, k, o] + rng.integers(0, 10 * (length - 1) + 1)
    return node, seg


def random_dp_case(rng, steps, oq, width, ndisp, dmin, most_runs):
    """The arguments of :func:`run_dp` for a random row: ``dmin`` moved down so the range
    fits the row, random costs, occlusion, orientation and slant costs, a run discount
    (0 in some cases: the plain model) and 1 to ``most_runs`` run states."""
    if dmin + ndisp - 1 >= width:
        dmin = width - ndisp
    node, seg = random_costs(rng, width, dmin, ndisp, oq, steps)
    occ = float(rng.integers(1, 15))
    orient, slant = (float(v) for v in rng.integers(0, 15, size=2))
    discount = float(rng.integers(0, occ))
    run_cap = int(rng.integers(1, most_runs + 1))
    return (node, seg, dmin, oq, occ, orient, slant, steps, discount, run_cap)


#: (steps, slopes in units of 1/steps): quarter-pixel sets and eighth-pixel sets (L = 8)
ORIENTATION_SETS = [
    (4, (0,)),
    (4, (0, 2)),
    (4, (-2, 0, 2)),
    (4, (-1, 0, 1, 4)),
    (4, (-4, 1)),
    (8, (-1, 0, 1)),
    (8, (-4, -2, 0, 4)),
    (16, (-8, 0, 4)),
]


@pytest.mark.parametrize("seed", range(24))
def test_scanline_dp_matches_oracle(seed):
    rng = np.random.default_rng(4100 + seed)
    steps, slopes = ORIENTATION_SETS[seed % len(ORIENTATION_SETS)]
    longest = max(naive_redert.segment(q, steps)[0] for q in slopes)
    width = int(rng.integers(2, 7)) if longest <= 4 else int(rng.integers(longest, longest + 2))
    ndisp = int(rng.integers(1, min(width, 3 if longest <= 4 else 2) + 1))
    dmin = int(rng.integers(-1, 2))
    oq = np.array(slopes, dtype=np.int64)
    args = random_dp_case(rng, steps, oq, width, ndisp, dmin, most_runs=3)
    expected = naive_redert.best_path_cost(*args)
    total, path = run_dp(*args)
    assert total == expected
    if expected < math.inf:
        cost = naive_redert.path_cost(path, *args)
        assert cost == pytest.approx(total)


@pytest.mark.parametrize("seed", range(40))
def test_scanline_dp_keeps_only_the_columns_it_reads(seed):
    # the table as a ring of the longest segment's columns plus one (what match_redert_rows
    # allocates) gives the path and cost of a table of every column, the ends along
    # j == width - 1 (x < width - 1) included: wider rows than the oracle can take
    rng = np.random.default_rng(7300 + seed)
    steps, slopes = ORIENTATION_SETS[seed % len(ORIENTATION_SETS)]
    oq = np.array(slopes, dtype=np.int64)
    longest = max(naive_redert.segment(q, steps)[0] for q in slopes)
    width = int(rng.integers(longest + 2, 48))
    ndisp = int(rng.integers(1, min(width, 12) + 1))
    dmin = int(rng.integers(-ndisp - 2, 3))
    args = random_dp_case(rng, steps, oq, width, ndisp, dmin, most_runs=4)
    expected = run_dp(*args)
    for ring in (longest + 1, longest + 3):
        assert run_dp(*args, ring=ring) == expected
    with pytest.raises(ValueError, match="the table must keep the longest segment's columns"):
        run_dp(*args, ring=longest)


@pytest.mark.parametrize("seed", range(30))
def test_scanline_dp_with_a_ring_matches_oracle(seed):
    # a ring shorter than the row (segments of at most two pixels: three columns) against
    # the exhaustive oracle, with ranges whose paths may end along j == width - 1 before
    # the last column (negative disparities): those ends are kept as their columns finish
    rng = np.random.default_rng(8800 + seed)
    steps, slopes = [(4, (0,)), (4, (0, 2)), (4, (-2, 0, 2)), (2, (-1, 0, 1))][seed % 4]
    oq = np.array(slopes, dtype=np.int64)
    ring = max(naive_redert.segment(q, steps)[0] for q in slopes) + 1
    width = int(rng.integers(ring + 1, 7))
    ndisp = int(rng.integers(1, 4))
    dmin = int(rng.integers(-3, 2))
    args = random_dp_case(rng, steps, oq, width, ndisp, dmin, most_runs=3)
    expected = naive_redert.best_path_cost(*args)
    total, path = run_dp(*args, ring=ring)
    assert total == expected
    if expected < math.inf:
        assert naive_redert.path_cost(path, *args) == pytest.approx(total)


def test_oracle_counts_a_hand_checked_tiny_case():
    # one disparity (0), two pixels, orientation 0 only: the only path is a diagonal
    # match from the virtual start (-1, -1) and one segment: 3 + 5 = 8.
    node = np.array([[[3.0]], [[4.0]]])
    seg = np.array([[[np.inf]], [[5.0]]])
    oq = np.array([0])
    totals = sorted(t for t, _ in naive_redert.enumerate_paths(node, seg, 0, oq, 9.0, 1.0, 0.0))
    assert totals == [3.0 + 5.0]
    assert run_dp(node, seg, 0, oq, 9.0, 1.0, 0.0)[0] == 8.0


#: Width 3, disparities 0..1, orientation 0: pixels 0 and 2 match at 1 at disparity 0,
#: pixel 1 badly (50) at either disparity.
TINY_NODE = np.array([[[1.0], [np.inf]], [[50.0], [50.0]], [[1.0], [50.0]]])
TINY_SEG = np.array([[[np.inf], [np.inf]], [[50.0], [np.inf]], [[1.0], [50.0]]])


def test_a_run_of_left_and_right_occlusions_is_discounted_after_its_first_pixel():
    # Best: match 0, occlude left pixel 1 then right pixel 1 (one run: 5, then 5 - 2),
    # match 2 diagonally: 1 + 5 + 3 + 1 = 10. The others: a border run from the start
    # (right 0, left 1, right 1 at 5 each, then 1) 16; going on to left pixel 2 instead
    # of matching it (the run's third pixel, beyond the cap of 2) 1 + 5 + 3 + 5 = 14;
    # matching pixel 1: 52.
    oq = np.array([0])
    args = (TINY_NODE, TINY_SEG, 0, oq, 5.0, 0.0, 0.0, 1, 2.0, 2)
    assert naive_redert.best_path_cost(*args) == 10.0
    total, path = run_dp(*args)
    assert total == 10.0
    assert [state for _, state in path] == [
        naive_redert.START,
        ("m", 0),
        ("l", 1),
        ("r", 2),
        ("m", 0),
    ]
    # without the discount every occluded pixel costs 5: 1 + 10 + 1
    assert run_dp(*args[:-2], 0.0, 2)[0] == 12.0
    assert run_dp(*args[:-2], 2.0, 1)[0] == 12.0


def test_a_run_from_the_start_gets_no_discount():
    # Pixel 0 cannot match (inf), so every path begins at the virtual start (0, -1): the
    # best is a border run (right 0, left 1, right 1) at 5 each, then pixel 2 matched:
    # 16, not the 5 + 3 + 3 + 1 a discounted run would cost.
    node = TINY_NODE.copy()
    node[0, 0, 0] = np.inf
    oq = np.array([0])
    args = (node, TINY_SEG, 0, oq, 5.0, 0.0, 0.0, 1, 2.0, 3)
    assert naive_redert.best_path_cost(*args) == 16.0
    total, path = run_dp(*args)
    assert total == 16.0
    assert [state for _, state in path] == [
        naive_redert.START,
        naive_redert.RIGHT_BORDER,
        naive_redert.LEFT_BORDER,
        naive_redert.RIGHT_BORDER,
        ("m", 0),
    ]


@pytest.mark.parametrize(
    ("radius", "steps", "slopes", "ndisp"),
    [
        (0, 4, (-4, -2, -1, 0, 1, 2, 4), 4),
        (1, 4, (-4, -2, -1, 0, 1, 2, 4), 4),
        (2, 4, (-4, -2, -1, 0, 1, 2, 4), 4),
        (1, 8, (-8, -4, -1, 0, 1, 2, 8), 4),
        (2, 8, (-4, -2, -1, 0, 1, 2, 4), 4),
        (2, 16, (-2, -1, 0, 1, 4), 4),
        # one disparity, a one-pixel window: a single cell per column, which every slope
        # steps over (no line goes on to the next column)
        (0, 4, (-4, -2, -1, 0, 1, 2, 4), 1),
        (0, 8, (-8, -1, 0, 1, 8), 1),
    ],
)
def test_sheared_costs_match_naive_windows(radius, steps, slopes, ndisp):
    # wide enough for whole 8- and 16-pixel segments away from the edges (the kernel's
    # weighted-column sum) and near them (the pixel-by-pixel sum of truncated windows)
    rng = np.random.default_rng(77)
    height, width, dmin = 4, 12 if steps == 4 else 26, -1
    oq = np.array(slopes, dtype=np.int64)
    omax = int(np.abs(oq).max())
    left = rng.integers(0, 4096, size=(height, width)).astype(np.int32)
    right = rng.integers(0, 4096, size=(height, width)).astype(np.int32)
    pad = ((radius, radius), (radius, radius))
    left_p, right_p = np.pad(left, pad, mode="edge"), np.pad(right, pad, mode="edge")
    e_lo = steps * dmin - radius * omax
    columns = np.empty((width, steps * (ndisp - 1) + 2 * radius * omax + 1), dtype=np.int64)
    node = np.empty((width, ndisp, oq.size))
    seg = np.empty_like(node)
    for y in range(height):
        redert.sample_columns(left_p, right_p, y, radius, steps, e_lo, columns)
        redert.sheared_costs(columns, e_lo, steps, dmin, oq, radius, node, seg)
        want_node, want_seg = naive_redert.row_costs(left, right, y, dmin, ndisp, oq, radius, steps)
        np.testing.assert_allclose(node, want_node, rtol=1e-12)
        np.testing.assert_allclose(seg, want_seg, rtol=1e-12)


@pytest.mark.parametrize(("radius", "steps", "dmin"), [(0, 4, -1), (2, 8, 0), (3, 16, 2)])
def test_sliding_column_sums_equal_fresh_ones(radius, steps, dmin):
    # the driver moves the vertical sums down a row (one row added, one taken away);
    # every row must hold the sums sample_columns makes afresh, the -1 cells included
    rng = np.random.default_rng(78)
    height, width, ndisp, omax = 9, 23, 5, steps // 2
    left = rng.integers(0, 4096, size=(height, width)).astype(np.int32)
    right = rng.integers(0, 4096, size=(height, width)).astype(np.int32)
    pad = ((radius, radius), (radius, radius))
    left_p, right_p = np.pad(left, pad, mode="edge"), np.pad(right, pad, mode="edge")
    e_lo = steps * dmin - radius * omax
    shape = (width, steps * (ndisp - 1) + 2 * radius * omax + 1)
    sliding = np.empty(shape, dtype=np.int64)
    fresh = np.empty(shape, dtype=np.int64)
    redert.sample_columns(left_p, right_p, 0, radius, steps, e_lo, sliding)
    assert (sliding == -1).any() and (sliding > 0).any()
    for y in range(1, height):
        redert.slide_columns(left_p, right_p, y, radius, steps, e_lo, sliding)
        redert.sample_columns(left_p, right_p, y, radius, steps, e_lo, fresh)
        np.testing.assert_array_equal(sliding, fresh)


def test_oracle_interpolates_between_right_pixels():
    # left pixel 4 (value 12) lies at right position 2.5, halfway between 16 and 8
    right = np.array([[0, 8, 16, 8, 0, 8, 16, 8]], dtype=np.int32)
    left = np.array([[0, 4, 4, 12, 12, 4, 4, 12]], dtype=np.int32)
    assert naive_redert.pixel_cost(left, right, 0, 4, 6, 0, 0) == 0.0  # d = 6 / 4
    assert naive_redert.pixel_cost(left, right, 0, 4, 4, 0, 0) == 4 * 4  # d = 1: |48 - 32|


def slanted_scores(method, slope, d0):
    rng = np.random.default_rng(5)
    left, right, truth = synthetic.slanted_pair(rng, 20, 100, d0, slope)
    result = dcstereo.match(
        left, right, max_disparity=int(np.nanmax(truth)) + 4, method=method, fill=True
    )
    error = np.abs(result.disparity - truth)[np.isfinite(truth)]
    return bad_pixel_rate(result.disparity, truth), float(error.mean())


@pytest.mark.parametrize(("slope", "d0"), [(0.5, 4), (0.25, 4), (-0.25, 30)])
def test_redert_follows_a_slanted_plane_that_dsi3_breaks(slope, d0):
    # Measured (20 x 100 pair, seed 5, default costs), bad-1 % / MAE px:
    # slope 0.5: dsi3 68.6 / 8.0, redert 0.0 / 0.005; slope 0.25: dsi3 23.4 / 1.12,
    # redert 0.0 / 0.02; slope -0.25: dsi3 19.7 / 0.82, redert 0.0 / 0.02.
    bad3, mae3 = slanted_scores("dsi3", slope, d0)
    bad_r, mae_r = slanted_scores("redert", slope, d0)
    assert bad_r <= 1.0
    assert bad3 >= bad_r + 15.0
    assert mae_r <= 0.1 * mae3


def test_slanted_plane_uses_the_slanted_orientation_without_occlusions():
    rng = np.random.default_rng(11)
    left, right, truth = synthetic.slanted_pair(rng, 12, 80, 4, 0.5)
    result, orientation = match_redert(
        left, right, MatchParams(max_disparity=48, method="redert"), with_orientation=True
    )
    inner = np.isfinite(truth)
    inner[:, :12] = False
    inner[:, -6:] = False
    assert np.mean(orientation[inner] == 0.5) >= 0.95
    assert np.mean(result.occluded[inner]) <= 0.02
    assert np.nanmax(np.abs(result.disparity - truth)[inner]) <= 0.5


def test_fronto_parallel_object_as_well_as_dsi3():
    rng = np.random.default_rng(23)
    left, right, truth = synthetic.object_pair(rng, 30, 90, 3, 11, (35, 65))
    scored = np.isfinite(truth)
    bad = {}
    for method in ("dsi3", "redert"):
        result = dcstereo.match(left, right, max_disparity=14, method=method, fill=True)
        bad[method] = bad_pixel_rate(result.disparity, truth, mask=scored)
    assert bad["redert"] <= bad["dsi3"] + 1.0
    assert bad["redert"] <= 3.0


def test_constant_disparity_is_exact():
    rng = np.random.default_rng(3)
    left, right = synthetic.constant_pair(rng, 16, 50, 6)
    result = dcstereo.match(left, right, max_disparity=10, method="redert")
    inner = result.disparity[:, 10:-2]
    np.testing.assert_array_equal(inner, 6.0)


def test_identity_gives_zero():
    rng = np.random.default_rng(8)
    image = synthetic.texture(rng, 14, 40)
    result = dcstereo.match(image, image, max_disparity=5, method="redert")
    np.testing.assert_array_equal(result.disparity, 0.0)
    assert result.flags.max() == 0
    np.testing.assert_array_equal(result.path_cost, 0.0)


def test_only_the_flat_orientation_is_dsi3():
    # with orientations (0,) and no run discount the model is the three-step DP
    rng = np.random.default_rng(9)
    left, right, _ = synthetic.object_pair(rng, 10, 60, 2, 7, (20, 40))
    three = dcstereo.match(left, right, max_disparity=9, method="dsi3", occlusion_cost=7)
    flat = dcstereo.match(
        left,
        right,
        max_disparity=9,
        method="redert",
        occlusion_cost=7,
        orientations=(0,),
        occlusion_discount=0,
    )
    np.testing.assert_array_equal(flat.disparity, three.disparity)
    np.testing.assert_array_equal(flat.flags, three.flags)
    np.testing.assert_allclose(flat.path_cost, three.path_cost, rtol=1e-12)


def test_flags_and_result_shape():
    rng = np.random.default_rng(13)
    left, right, truth = synthetic.object_pair(rng, 12, 60, 2, 9, (25, 45))
    result = dcstereo.match(left, right, max_disparity=12, method="redert")
    assert result.disparity.dtype == np.float32 and result.disparity.shape == (12, 60)
    assert result.path_cost.shape == (12,)
    assert result.method == "redert"
    # the left border has no partner; occluded pixels sit left of the object
    assert np.all(result.flags[:, :2] == dcstereo.FLAG_BORDER)
    occluded = (result.flags & dcstereo.FLAG_OCCLUDED) != 0
    assert np.all(np.isnan(result.disparity[occluded]))
    assert occluded[:, 16:25].mean() >= 0.5
    filled = result.filled()
    assert np.isfinite(filled.disparity).all()


def test_orientation_steps():
    steps, oq = orientation_steps((-1, -0.5, 0.25, 0))
    assert steps == 4
    np.testing.assert_array_equal(oq, [-4, -2, 1, 0])
    steps, oq = orientation_steps((-0.5, -0.25, -0.125, 0, 0.125, 0.25, 0.5))
    assert steps == 8
    np.testing.assert_array_equal(oq, [-4, -2, -1, 0, 1, 2, 4])
    assert orientation_steps((0,))[0] == 1
    assert orientation_steps((0.0625,))[0] == 16


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"orientations": (0.3,)}, "orientations must be slopes"),
        ({"orientations": (0.03125,)}, "orientations must be slopes"),
        ({"orientations": (0.75,)}, "orientations must be slopes"),
        ({"orientations": (2,)}, "orientations must be slopes"),
        ({"orientations": ()}, "at least one slope"),
        ({"orientations": (0, 0.0)}, "must not repeat"),
        ({"orientations": "0"}, "sequence of slopes"),
        ({"orientations": (float("nan"),)}, "orientations must be slopes"),
        ({"orientation_cost": -1}, "orientation_cost must be a non-negative number"),
        ({"orientation_cost": float("inf")}, "orientation_cost must be finite"),
        ({"orientation_cost": "1"}, "orientation_cost must be a non-negative number"),
        ({"slant_cost": -2}, "slant_cost must be a non-negative number"),
        ({"occlusion_discount": -0.1}, r"occlusion_discount must be a number in \[0, 1\)"),
        ({"occlusion_discount": 1}, r"occlusion_discount must be a number in \[0, 1\)"),
        ({"occlusion_discount": float("nan")}, "occlusion_discount must be a number"),
        ({"occlusion_discount": "0.2"}, "occlusion_discount must be a number"),
        ({"occlusion_discount_pixels": -1}, "occlusion_discount_pixels must be 0 to 64"),
        ({"occlusion_discount_pixels": 65}, "occlusion_discount_pixels must be 0 to 64"),
        ({"occlusion_cost": 0}, "occlusion_cost must be positive"),
    ],
)
def test_bad_parameters_raise(options, message):
    image = np.zeros((8, 20), dtype=np.uint8)
    with pytest.raises(ValueError, match=message):
        dcstereo.match(image, image, max_disparity=3, method="redert", **options)


def test_occlusion_discount_pixels_must_be_an_integer():
    image = np.zeros((8, 20), dtype=np.uint8)
    with pytest.raises(TypeError, match="occlusion_discount_pixels must be an integer"):
        dcstereo.match(
            image, image, max_disparity=3, method="redert", occlusion_discount_pixels=2.5
        )
    params = MatchParams(max_disparity=3, method="redert", occlusion_discount_pixels=4.0)
    assert params.occlusion_discount_pixels == 4


def test_orientations_accept_a_list():
    params = MatchParams(max_disparity=3, method="redert", orientations=[0, 0.5])
    assert params.orientations == (0.0, 0.5)


def test_match_redert_checks_its_inputs():
    params = MatchParams(max_disparity=3, method="redert")
    with pytest.raises(ValueError, match="differ in shape"):
        match_redert(np.zeros((8, 20), np.uint8), np.zeros((8, 21), np.uint8), params)


def test_cli_runs_redert(tmp_path):
    from dcstereo.cli import main

    rng = np.random.default_rng(101)
    left, right, _ = synthetic.object_pair(rng, 16, 48, 2, 7, (18, 32))
    Image.fromarray(left).save(tmp_path / "left.png")
    Image.fromarray(right).save(tmp_path / "right.png")
    out = tmp_path / "disp.pfm"
    result = CliRunner().invoke(
        main,
        [
            "run",
            str(tmp_path / "left.png"),
            str(tmp_path / "right.png"),
            "-o",
            str(out),
            "--max-disparity",
            "9",
            "--method",
            "redert",
        ],
        catch_exceptions=False,
    )
    assert result.exit_code == 0, result.output
    assert out.exists()


@pytest.mark.dataset
@pytest.mark.slow
def test_venus_redert_against_dsi3(middlebury_root):
    from dcstereo.evaluation.datasets import load_middlebury

    data = load_middlebury("venus", root=middlebury_root.parent)
    bad, bad_half, mae = {}, {}, {}
    nonocc = data.masks["nonocc"]
    for method in ("dsi3", "redert"):
        result = dcstereo.match(
            data.left, data.right, max_disparity=data.max_disparity, method=method, fill=True
        )
        bad[method] = bad_pixel_rate(result.disparity, data.disparity, mask=nonocc)
        bad_half[method] = bad_pixel_rate(
            result.disparity, data.disparity, threshold=0.5, mask=nonocc
        )
        mae[method] = mean_abs_error(result.disparity, data.disparity, mask=nonocc)
    # Measured (defaults: slopes down to 1/8, orientation cost 0.5, slant 9, occlusion
    # runs discounted by 0.2 for 5 pixels after their first): bad-1.0 dsi3 3.85 %,
    # redert 3.42 % (4.01 % with the former defaults, which had no run discount);
    # bad-0.5 10.88 % / 10.06 %; MAE 0.412 / 0.380 px. The cheaper runs let the path
    # leave and rejoin a surface across textureless stretches (see docs/redert_tuning.md).
    assert bad["redert"] <= 0.9 * bad["dsi3"]
    assert bad_half["redert"] < bad_half["dsi3"]
    assert mae["redert"] < mae["dsi3"]
