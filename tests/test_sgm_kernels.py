"""The sgm kernels against their naive twins (tests/naive_sgm.py), bit for bit."""

import numba
import numpy as np
import pytest

import dcstereo
import naive_sgm
from dcstereo._vector import sgm as sgm_simd
from dcstereo.aggregate import sgm as sgm_kernels
from dcstereo.costs import census as census_kernels
from dcstereo.methods import sgm
from dcstereo.params import MatchParams
from dcstereo.signal import padded_signal

LANES = sgm_simd.LANES


# --------------------------------------------------------------------------- vector code


def _path_inputs(rng, n):
    cost = rng.integers(0, 1000, 3 * n + 8).astype(np.int16)
    prev = rng.integers(0, 3000, 3 * n + 8).astype(np.int16)
    prev[3] = prev[3 + n + 1] = 16383  # the pads
    return cost, prev


@pytest.mark.parametrize("n", [LANES, 2 * LANES, 5 * LANES])
def test_path_step_vector_form_equals_plain_form(n):
    rng = np.random.default_rng(n)
    for _ in range(40):
        cost, prev = _path_inputs(rng, n)
        pmin = int(prev[4 : 4 + n].min())
        p1, p2 = int(rng.integers(0, 600)), int(rng.integers(0, 4000))
        plain, vector = np.zeros(3 * n, np.int16), np.zeros(3 * n, np.int16)
        expected = sgm_simd.path_step(cost, 5, prev, 3, plain, 7, n, p1, p2, pmin)
        got = sgm_simd.compiled_path_step(cost, 5, prev, 3, vector, 7, n, p1, p2, pmin)
        assert got == expected
        np.testing.assert_array_equal(vector, plain)


def test_path_step_by_hand():
    # C = (3, 1, 4), L(q) = (0, 5, 2), P1 = 1, P2 = 3, min L(q) = 0:
    # k0: 3 + min(0, 5 + 1, 0 + 3) = 3; k1: 1 + min(5, 0 + 1, 2 + 1, 3) = 2;
    # k2: 4 + min(2, 5 + 1, 3) = 6; the padding lanes (cost 9000) stay above.
    cost = np.full(LANES, 9000, np.int16)
    cost[:3] = (3, 1, 4)
    prev = np.full(LANES + 2, 9000, np.int16)
    prev[0] = prev[-1] = 16383
    prev[1:4] = (0, 5, 2)
    for step in (sgm_simd.path_step, sgm_simd.compiled_path_step):
        cur = np.zeros(LANES + 2, np.int16)
        assert step(cost, 0, prev, 0, cur, 0, LANES, 1, 3, 0) == 2
        assert list(cur[1:4]) == [3, 2, 6]


def test_path_step_saturates_at_int16():
    n = LANES
    cost = np.zeros(n, np.int16)
    prev = np.full(n + 2, 32000, np.int16)
    for step in (sgm_simd.path_step, sgm_simd.compiled_path_step):
        cur = np.zeros(n + 2, np.int16)
        step(cost, 0, prev, 0, cur, 0, n, 5000, 5000, 32000)
        assert (cur[1:-1] == 0).all()  # min(32000, 32767 (saturated), 32767) - 32000


def test_path_start_add_and_first_min_vector_forms():
    rng = np.random.default_rng(3)
    for n in (LANES, 3 * LANES):
        for _ in range(20):
            cost = rng.integers(-500, 500, 4 * n).astype(np.int16)
            a, b = np.zeros(4 * n, np.int16), np.zeros(4 * n, np.int16)
            assert sgm_simd.path_start(cost, 3, a, 5, n) == sgm_simd.compiled_path_start(
                cost, 3, b, 5, n
            )
            np.testing.assert_array_equal(a, b)
            x = rng.integers(-32768, 32768, 4 * n).astype(np.int16)
            y = rng.integers(-32768, 32768, 4 * n).astype(np.int16)
            sgm_simd.add_saturated(a, 1, x, 2, y, 9, n)
            sgm_simd.compiled_add_saturated(b, 1, x, 2, y, 9, n)
            np.testing.assert_array_equal(a, b)
            ties = rng.integers(0, 4, 4 * n).astype(np.int16)  # many ties: the first wins
            assert sgm_simd.first_min(ties, 6, n) == sgm_simd.compiled_first_min(ties, 6, n)
            assert sgm_simd.first_min(ties, 6, n)[0] == int(np.argmin(ties[6 : 6 + n]))


def test_the_operations_of_a_pixel_are_inlined():
    # a call a pixel pushed every array and offset on the stack, more than the vector loop's
    # time at 64 disparities: the caller's code holds the operations, no call to them
    import numba as nb

    @nb.njit
    def caller(cost, prev, cur, mins, sums, parts, total):
        sgm_simd.paths_step(cost, 0, prev, (0, 18), cur, (0, 18), 16, 3, (9, 9), mins, sums, 0)
        sgm_simd.path_step(cost, 0, prev, 0, cur, 0, 16, 3, 9, 0)
        sgm_simd.add_saturated(sums, 0, sums, 0, cur, 1, 16)
        return sgm_simd.path_total_step(
            cost, 0, prev, 0, cur, 0, 16, 3, 9, 0, parts, (0, 0, 0), total, 0
        )

    values = np.zeros(64, np.int16)
    parts = (values, values, values)
    args = (values, values.copy(), values.copy(), np.zeros(2, np.int64), values.copy(), parts,
            values.copy())  # fmt: skip
    assert caller(*args) == (0, 0, 0)
    code = caller.inspect_llvm(caller.signatures[0])
    for name in ("paths_step", "path_step", "add_saturated", "path_total_step"):
        assert f"{name}_compiled" not in code, name


def test_prefetch_is_a_hint():
    # no value changes; compiled, it asks for the lines (llvm.prefetch in the code)
    from dcstereo._vector import VECTOR

    values = np.arange(100, dtype=np.int16)
    assert sgm_simd.prefetch_pixel(values, 0, 64) is None
    sgm_simd.compiled_prefetch_pixel(values, 4, 96)
    assert values.tolist() == list(range(100))
    # compiled afresh: the cached kernel, loaded from an earlier process's cache, has no code
    # to inspect
    kernel = numba.njit(sgm_simd.compiled_prefetch_pixel.py_func)
    kernel(values, 4, 96)
    code = kernel.inspect_llvm(kernel.signatures[0])
    assert ("@llvm.prefetch" in code) == VECTOR


# --------------------------------------------------------------------------- costs


@pytest.mark.parametrize(("rows", "cols"), [(3, 3), (5, 5), (3, 7), (1, 9), (7, 9)])
def test_census_transform_equals_twin(rows, cols):
    rng = np.random.default_rng(rows * 10 + cols)
    image = rng.integers(0, 6, (9, 13)).astype(np.uint8)  # many equal neighbours
    signal = padded_signal(image, 0)
    out = np.empty(signal.shape, np.uint64)
    sgm._census(signal, rows, cols, out)
    np.testing.assert_array_equal(out, naive_sgm.census(signal, rows, cols))


def _costs_inputs(seed, colour, height=7, width=19):
    rng = np.random.default_rng(seed)
    shape = (height, width, 3) if colour else (height, width)
    left = rng.integers(0, 256, shape).astype(np.uint8)
    right = rng.integers(0, 256, shape).astype(np.uint8)
    return left, right


#: Census windows and the codes' type: 24 bits in uint32 (both 16-bit planes in use), 14
#: bits in uint64 (the high 32-bit plane all zeros), 62 bits in uint64.
CODES = [((5, 5), np.uint32), ((3, 5), np.uint64), ((7, 9), np.uint64)]


@pytest.mark.parametrize(("census", "kind"), CODES)
@pytest.mark.parametrize("colour", [False, True])
@pytest.mark.parametrize(("dmin", "dmax", "box"), [(0, 6, 3), (-3, 4, 1), (2, 9, 5), (-5, -1, 3)])
def test_cost_volume_equals_twin(colour, dmin, dmax, box, census, kind):
    left, right = _costs_inputs(dmax - dmin + box, colour)
    params = MatchParams(
        max_disparity=dmax, min_disparity=dmin, method="sgm", window=box, census_window=census
    )
    height, width = left.shape[:2]
    ndisp = dmax - dmin + 1
    codes_l = np.empty((height, width), kind)
    codes_r = np.empty((height, width), kind)
    sgm._census(padded_signal(left, 0), *census, codes_l)
    sgm._census(padded_signal(right, 0), *census, codes_r)
    colour_l, colour_r = sgm.colour_channels(left, right)
    bit_cost = sgm.census_bit_cost(census)
    expected = naive_sgm.box_mean(
        naive_sgm.pixel_costs(codes_l, codes_r, colour_l, colour_r, dmin, ndisp, bit_cost, 20),
        box,
    )
    after = max(0, -dmin)
    lanes = -(-ndisp // LANES) * LANES
    largest = sgm.UNITS * sgm.largest_pixel_cost(params)
    reciprocal = census_kernels.box_reciprocal(box, largest * box * box)
    # the right rows padded for the disparities only (the kernel computes ndisp lanes), and
    # for every lane (as sgm pads them: all lanes computed, the padding set after)
    for pad in (max(0, dmax), max(0, dmax + lanes - ndisp)):
        for begin, rows in ((0, height), (2, 3)):  # the whole image, and a strip of it
            out = np.empty((rows, width, lanes), np.int16)
            census_kernels.cost_volume(
                census_kernels.code_planes(codes_l),
                sgm._reversed_right(census_kernels.code_planes(codes_r), pad, after), colour_l,
                sgm._reversed_right(colour_r, pad, after), dmin, ndisp, bit_cost, 20, box,
                reciprocal, 7777, begin, out,
            )  # fmt: skip
            np.testing.assert_array_equal(out[:, :, :ndisp], expected[begin : begin + rows])
            assert (out[:, :, ndisp:] == 7777).all()


@pytest.mark.parametrize("box", [1, 3, 5])
def test_box_row_equals_twin(box):
    # one row of the box mean from a ring of per-pixel rows, narrow rows included (the
    # 3 x 3 box's rolling column sums at widths 1 and 2), the padding lanes set; the
    # column sums stay within box_scratch's values (a guard after them is left alone)
    rng = np.random.default_rng(box)
    for width in (1, 2, 3, 17):
        span, ndisp = 32, 27
        ring = rng.integers(0, 1200, (box, width, span)).astype(np.int16)
        size = census_kernels.box_scratch(width, box, span)
        assert size == (3 * span if box == 3 else (width + box - 1) * span)
        vertical = np.full(size + span, -1, np.int16)
        out = np.full((width, span), -1, np.int16)
        reciprocal = census_kernels.box_reciprocal(box, 1200 * box * box)
        census_kernels._box_row(ring, width, span, box, reciprocal, vertical, out, 777, ndisp)
        sums = ring.astype(np.int64).sum(axis=0)
        padded = np.pad(sums, ((box // 2, box // 2), (0, 0)), mode="edge")
        window = sum(padded[dx : dx + width] for dx in range(box))
        expected = window // (box * box)
        np.testing.assert_array_equal(out[:, :ndisp], expected[:, :ndisp], err_msg=str(width))
        assert (out[:, ndisp:] == 777).all()
        assert (vertical[size:] == -1).all()


def test_box3_row_by_hand():
    # one lane, three pixels, rows summing to 9, 18, 36 a column: pixel 0's box repeats
    # column 0 (9 + 9 + 18 = 36, a mean of 4), pixel 1 (9 + 18 + 36) // 9 = 7, pixel 2
    # (18 + 36 + 36) // 9 = 10
    ring = np.array([[[3], [6], [12]]] * 3, dtype=np.int16)
    out = np.empty((3, 1), np.int16)
    census_kernels._box_row(ring, 3, 1, 3, np.float32(1 / 9), np.empty(3, np.int16), out, 0, 1)
    assert out[:, 0].tolist() == [4, 7, 10]


def test_cost_span_by_hand():
    # 10 left columns, disparities 2..6 (5 of them, 16 lanes): left pixel 0 reads right
    # columns 9 + 2 + k (the reversed layout), so k up to 15 needs 27 columns
    span = census_kernels.cost_span.py_func
    assert span(10, 10 + 6, 2, 5, 16) == 5  # padded for the disparities only
    assert span(10, 26, 2, 5, 16) == 15
    assert span(10, 27, 2, 5, 16) == 16
    assert span(10, 40, 2, 5, 16) == 16  # never past the lanes
    # disparities -3..1: after = 3 (right columns 9 - 3 + 3 + k), pad = 1 for them alone,
    # 1 + 11 for every lane
    assert span(10, 10 + 1 + 3, -3, 5, 16) == 5
    assert span(10, 10 + 12 + 3, -3, 5, 16) == 16


def test_code_planes_by_hand():
    planes = census_kernels.code_planes(np.array([[0x12345678, 0xFFFF0001]], np.uint32))
    assert planes.dtype == np.uint16 and planes.shape == (2, 1, 2)
    assert planes[:, 0].tolist() == [[0x5678, 0x0001], [0x1234, 0xFFFF]]
    wide = census_kernels.code_planes(np.array([[0x0123456789ABCDEF]], np.uint64))
    assert wide.dtype == np.uint32 and wide[:, 0, 0].tolist() == [0x89ABCDEF, 0x01234567]
    for bad in (np.zeros((2, 2), np.int64), np.zeros((1, 2, 2), np.uint32)):
        with pytest.raises(ValueError, match="census codes must be 2-D uint32 or uint64"):
            census_kernels.code_planes(bad)


def test_pixel_cost_row_counts_both_planes_by_hand():
    # one left pixel, disparities 0 and 1 (right pixels 0 and -1, the latter the repeated
    # edge), census only: left 0x00030001 against right 0x00010003 differs in bit 1 of
    # each 16-bit half, 2 bits: 3 * bit_cost * 2 = 24 with bit_cost 4
    left = census_kernels.code_planes(np.array([[0x00030001]], np.uint32))
    right = census_kernels.code_planes(np.array([[0x00010003]], np.uint32))
    right = sgm._reversed_right(right, 1, 0)  # padded for disparity 1, reversed
    out = np.zeros((1, 2), np.int16)
    grey = np.zeros((1, 1, 2), np.uint8)
    census_kernels.pixel_cost_row(left, right, grey[:, :, :1], grey, 0, 0, 2, 4, 0, out)
    assert out.tolist() == [[24, 24]]


def test_box_reciprocal_is_exact_or_refused():
    for box in (1, 3, 5, 7, 9):
        largest = min(32767, 300 * box * box)
        r = census_kernels.box_reciprocal(box, largest)
        sums = np.arange(largest + 1)
        np.testing.assert_array_equal(
            (sums.astype(np.float32) * r).astype(np.int64), sums // (box * box)
        )
    with pytest.raises(ValueError, match="too large"):
        census_kernels.box_reciprocal(3, 40000)


def test_the_3x3_box_multiplier_is_the_floor_of_a_ninth():
    sums = np.arange(32768, dtype=np.int64)  # every int16 box sum the volume can hold
    np.testing.assert_array_equal((sums * census_kernels.BOX3_MULTIPLIER) >> 16, sums // 9)
    assert (32767 * census_kernels.BOX3_MULTIPLIER) >> 16 == 3640  # by hand: 32767 // 9


# --------------------------------------------------------------------------- pipeline


def _naive_sgm(left, right, params):
    """The raw sgm map (no fill) by the twins."""
    rows, cols = params.census_window
    codes_l = naive_sgm.census(padded_signal(left, 0), rows, cols)
    codes_r = naive_sgm.census(padded_signal(right, 0), rows, cols)
    colour_l, colour_r = sgm.colour_channels(left, right)
    ad_max = params.ad_truncation if params.cost == "census-ad" else 0
    costs = naive_sgm.pixel_costs(
        codes_l, codes_r, colour_l, colour_r, params.min_disparity, params.num_disparities,
        sgm.census_bit_cost(params.census_window), ad_max,
    )  # fmt: skip
    costs = naive_sgm.box_mean(costs, params.window)
    table = sgm.UNITS * sgm.p2_table(params)
    sums = naive_sgm.aggregate(
        costs, padded_signal(left, 0), sgm.UNITS * params.p1, table, params.paths
    )
    return naive_sgm.choose(sums, params.min_disparity, params.lr_tolerance, params.subpixel)


CASES = [
    {"max_disparity": 6},
    {"max_disparity": 6, "paths": 4, "subpixel": "parabola"},
    {"max_disparity": 3, "min_disparity": -4, "cost": "census", "subpixel": "equiangular"},
    {"max_disparity": 9, "min_disparity": 2, "census_window": (3, 7), "window": 1},
    {"max_disparity": 20, "window": 5, "p1": 10, "p2": 90, "p2_gradient": 0, "lr_tolerance": 0},
    {"max_disparity": 5, "lr_tolerance": None, "p2_gradient": 2.5, "ad_truncation": 7},
]


PLANS = [sgm_kernels.PLAN_SWEEP, sgm_kernels.PLAN_PASSES, sgm_kernels.PLAN_SPLIT]


@pytest.mark.parametrize("plan", PLANS)  # each of paths_and_choices' three, whatever the load
@pytest.mark.parametrize("colour", [False, True])
@pytest.mark.parametrize("case", CASES)
def test_sgm_equals_twin(case, colour, plan, monkeypatch):
    left, right = _costs_inputs(len(str(case)), colour, height=8 + colour, width=26)  # odd too
    right = np.roll(left, -3, axis=1) // 2 + right // 2  # something to match
    params = MatchParams(method="sgm", fill=False, median=0, **case)
    chosen = []

    def forced(width, threads):
        chosen.append(plan)
        return plan

    monkeypatch.setattr(sgm_kernels, "aggregation_plan", forced)
    before = numba.get_num_threads()
    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
    try:
        result = sgm.match_sgm(left, right, params)
    finally:
        numba.set_num_threads(before)
    assert chosen  # the plan was asked for, so the forced one ran
    disparity, flags = _naive_sgm(left, right, params)
    np.testing.assert_array_equal(result.flags, flags)
    np.testing.assert_array_equal(result.disparity, disparity)


def test_strips_are_exact_where_one_strip_holds_the_image(monkeypatch):
    rng = np.random.default_rng(5)
    left = rng.integers(0, 256, (40, 50), dtype=np.uint8)
    right = np.roll(left, -4, axis=1)
    params = MatchParams(method="sgm", max_disparity=8, fill=False, median=0)
    whole = sgm.match_sgm(left, right, params)
    # a bound that makes strips of 5 rows with 32 rows of context covers this image whole
    per_row = 50 * 16 * 2 * 3
    monkeypatch.setattr(sgm, "VOLUME_BYTES", per_row * (5 + 2 * sgm.STRIP_MARGIN))
    before = numba.get_num_threads()
    for threads in (1, min(2, numba.config.NUMBA_NUM_THREADS)):  # one: the fused sweep up
        numba.set_num_threads(threads)
        try:
            strips = sgm.match_sgm(left, right, params)
        finally:
            numba.set_num_threads(before)
        np.testing.assert_array_equal(strips.disparity, whole.disparity)
        np.testing.assert_array_equal(strips.flags, whole.flags)


@pytest.mark.parametrize("channels", [1, 3])
def test_fill_equals_twin(channels):
    from dcstereo.refine.consistency import fill_with_colour
    from dcstereo.result import FLAG_FILLED, FLAG_MISMATCH, FLAG_OCCLUDED, DisparityResult

    rng = np.random.default_rng(channels)
    for _ in range(20):
        height, width = (int(v) for v in rng.integers(1, 14, 2))
        disparity = rng.integers(0, 9, (height, width)).astype(np.float32)
        holes = rng.random((height, width)) < rng.uniform(0.1, 0.9)
        disparity[holes] = np.nan
        flags = np.where(holes, FLAG_OCCLUDED, 0).astype(np.uint8)
        mismatch = holes & (rng.random((height, width)) < 0.5)
        flags[mismatch] = FLAG_MISMATCH
        colour = rng.integers(0, 4, (channels, height, width)).astype(np.int16)  # ties
        result = DisparityResult(disparity, flags, MatchParams(max_disparity=8), np.zeros(height))
        filled = fill_with_colour(result, colour)
        expected = naive_sgm.fill(disparity, mismatch, colour)
        np.testing.assert_array_equal(filled.disparity, expected)
        done = holes & np.isfinite(expected)
        np.testing.assert_array_equal(filled.flags, flags | np.where(done, FLAG_FILLED, 0))


def test_sgm_kernels_run_as_plain_python(tmp_path):
    # NUMBA_DISABLE_JIT=1: the kernels and the plain forms of the vector code run as Python
    # (coverage sees them) and give the compiled result
    import os
    import subprocess
    import sys

    rng = np.random.default_rng(4)
    left = rng.integers(0, 256, (7, 21, 3), dtype=np.uint8)
    right = np.roll(left, -2, axis=1)
    np.savez(tmp_path / "pair.npz", left=left, right=right)
    options = {"max_disparity": 5, "min_disparity": -1}
    compiled = dcstereo.match(left, right, **options)
    code = (
        "import numpy as np, dcstereo\n"
        f"pair = np.load({str(tmp_path / 'pair.npz')!r})\n"
        f"r = dcstereo.match(pair['left'], pair['right'], **{options!r})\n"
        f"np.savez({str(tmp_path / 'plain.npz')!r}, d=r.disparity, f=r.flags)\n"
    )
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    plain = np.load(tmp_path / "plain.npz")
    np.testing.assert_array_equal(plain["d"], compiled.disparity)
    np.testing.assert_array_equal(plain["f"], compiled.flags)


@pytest.mark.parametrize(
    ("dtype", "shape", "before", "after"),
    [
        (np.uint32, (5, 9), 4, 0),
        (np.uint64, (3, 7), 0, 3),
        (np.int16, (3, 4, 6), 5, 2),
        (np.int16, (1, 1, 1), 2, 2),
    ],
)
def test_reversed_right_equals_pad_then_reverse(dtype, shape, before, after):
    # the one-pass kernel against its definition: numpy's edge padding, then reversed
    rng = np.random.default_rng(sum(shape) + before)
    array = rng.integers(0, 200, shape).astype(dtype)
    widths = [(0, 0)] * (array.ndim - 1) + [(before, after)]
    expected = np.pad(array, widths, mode="edge")[..., ::-1]
    got = sgm._reversed_right(array, before, after)
    assert got.dtype == dtype and got.flags.c_contiguous
    np.testing.assert_array_equal(got, expected)


def test_reversed_padded_rows_by_hand():
    # row 1 2 3, one repeated first value before and two repeated last ones after:
    # 1 1 2 3 3 3, reversed 3 3 3 2 1 1
    rows = np.array([[1, 2, 3]], dtype=np.uint32)
    np.testing.assert_array_equal(
        census_kernels.reversed_padded_rows(rows, 1, 2), [[3, 3, 3, 2, 1, 1]]
    )
