"""The hand-written vector code (``dcstereo._vector.simd*``) against its plain forms.

Each operation of the ``simd`` modules is a plain-Python function whose compiled callers
get LLVM vector code (an ``@overload``); these tests call both, the plain form as Python
and the vector form from a compiled caller, and hold them to each other (and to numpy or a
naive twin), byte for byte.
"""

import time

import numba
import numpy as np
import pytest
from llvmlite import ir
from numba.core import types
from numba.extending import intrinsic

import naive
from dcstereo import _signal as signal
from dcstereo._vector import costs as simd_costs
from dcstereo._vector import dp as simd_dp
from dcstereo._vector import simd
from dcstereo.costs import band as band_costs
from dcstereo.divide import band_match, divide_bands
from dcstereo.scanline import dp


def _compiled(function):
    """``function`` called from compiled code (its vector form, through ``overload``).

    One compiled caller per number of arguments, each spelled out: an overload inlined in
    numba's IR (``_cells5_chain``'s) cannot be called with ``*args``.
    """
    callers = {}

    def call(*args):
        if len(args) not in callers:
            names = ", ".join(f"a{i}" for i in range(len(args)))
            scope = {"function": function}
            exec(f"def caller({names}):\n    return function({names})", scope)
            callers[len(args)] = numba.njit(scope["caller"])
        return callers[len(args)](*args)

    return call


@pytest.mark.parametrize("seed", range(4))
def test_keyed_column_vector_code_equals_its_twin_and_the_naive_one(seed):
    # the keyed column's LLVM vector code (compiled) and its plain-Python twin, on columns
    # of both parities of block count, at an offset in the band and in the outputs
    rng = np.random.default_rng(700 + seed)
    nr = simd.BAND_ROWS
    compiled = _compiled(simd_costs._keyed_column)
    for ndisp in list(range(1, 9)) + [int(n) for n in rng.integers(9, 70, 6)]:
        nblocks = ndisp + 2
        scale = band_match._key_scale(nblocks)
        cells = rng.integers(0, 4, (ndisp, nr)).astype(np.float64)  # ties and zeros
        cells[rng.random(cells.shape) < 0.2] = np.inf
        cells[:, int(rng.integers(0, nr))] = np.inf  # a lane with no match
        if rng.random() < 0.5:  # the keys' range: costs up to 2**31 - 1
            cells = np.where(np.isinf(cells), cells, 2.0**31 - 1 - cells)
        column = np.full((nblocks, nr), np.inf)
        column[1:-1] = cells
        cost = np.concatenate([rng.random(3 * nblocks * nr), column.ravel()])
        o = np.uint64(3 * nblocks * nr)
        expected_k, expected_ratio = naive.naive_block_match(cells)
        numbers = np.arange(nblocks + int(rng.integers(0, 3)), dtype=np.float64)
        for run in (simd_costs._keyed_column, compiled):
            wta_k = np.full(3 * nr, 99, dtype=np.int64)
            wta_ratio = np.full(3 * nr, -5.0)
            run(cost, o, nblocks, scale, numbers, wta_k, wta_ratio, np.uint64(nr))
            assert list(wta_k[nr : 2 * nr]) == expected_k
            np.testing.assert_array_equal(wta_ratio[nr : 2 * nr], expected_ratio)
            assert (wta_k[:nr] == 99).all() and (wta_k[2 * nr :] == 99).all()
            assert (wta_ratio[:nr] == -5.0).all() and (wta_ratio[2 * nr :] == -5.0).all()


def test_floor_log2_compiled_equals_its_twin():
    # the sparse table's level of an interval of n candidates: lzcnt against bit_length
    compiled = _compiled(simd._floor_log2)
    values = [1, 2, 3, 4, 5, 7, 8, 9, 1023, 1024, 1025, 2**40 - 1, 2**40, 2**62, 2**63 - 1]
    for n in values + [int(n) for n in np.random.default_rng(5).integers(1, 2**31, 50)]:
        expected = int(np.floor(np.log2(float(n)))) if n < 2**50 else n.bit_length() - 1
        assert simd._floor_log2(n) == expected == compiled(np.int64(n)), n


def ssd_in_form(form):
    """Compiled: ``_window_ssd`` in ``form``, a constant there (as the search calls it)."""

    @numba.njit
    def window_ssd(left_p, right_p, y, x, j, radius):
        return simd._window_ssd(left_p, right_p, y, x, j, radius, form)

    return window_ssd


def numpy_window_sums(left, right, y, x, j, win):
    """``_window_ssd``'s ``(ssd, sm, sq)`` of windows ``(y, x)`` and ``(y, j)``, by numpy."""
    right_window = right[y : y + win, j : j + win].astype(np.int64)
    diff = left[y : y + win, x : x + win].astype(np.int64) - right_window
    return (
        float((diff * diff).sum()),
        int(right_window.sum()),
        int((right_window * right_window).sum()),
    )


@pytest.mark.parametrize("seed", range(3))
def test_window_ssd_vector_code_equals_its_twin_and_numpy(seed):
    # the SSD and the right window's sum and sum of squares; windows of one to 25 pixels a
    # side (a row of more than R pixels takes several masked loads), against the image's
    # edges (nothing past the window is read: a read past the array's end could fault), on
    # signals whose squares need 64 bits
    rng = np.random.default_rng(900 + seed)
    wide, short = (ssd_in_form(f) for f in (simd.SSD_WIDE, simd.SSD_SHORT))
    for radius in range(13):
        win = 2 * radius + 1
        height, width = win + int(rng.integers(0, 3)), win + int(rng.integers(0, 20))
        high = 2**25 if rng.random() < 0.5 else 4081  # 625 squares of 2**26: below 2**63
        left = rng.integers(-high, high, (height, width)).astype(np.int32)
        right = rng.integers(-high, high, (height, width)).astype(np.int32)
        for y, x, j in [(height - win, width - win, width - win), (0, 0, width - win)] + [
            (int(rng.integers(0, height - win + 1)), int(rng.integers(0, width - win + 1)),
             int(rng.integers(0, width - win + 1)))
            for _ in range(5)
        ]:  # fmt: skip
            expected = numpy_window_sums(left, right, y, x, j, win)
            bound = max(abs(int(left.min())), abs(int(left.max())), high)
            narrow = bool(divide_bands._narrow_sums(2 * high, bound, radius))
            assert narrow == (high == 4081 and radius <= 2)  # 25 * (2 * 4081)**2 < 2**31
            forms = [wide] + [short] * (narrow and win <= simd.BAND_ROWS)
            assert len(forms) == 1 + (radius <= 2 and high == 4081)
            for got in (
                simd._window_ssd(left, right, y, x, j, radius, simd.SSD_WIDE),
                *(form(left, right, y, x, j, radius) for form in forms),
            ):
                assert tuple(got) == expected
                assert isinstance(got[0], float)


@pytest.mark.parametrize("radius", [0, 1, 2, 3])
def test_narrow_window_ssd_holds_sums_up_to_its_bound(radius):
    # the search's SSD in 32-bit lanes (SSD_SHORT, windows of at most R pixels a side)
    # where _narrow_sums says the sums fit: at the largest signal that fits (the SSD and the
    # right window's sum of squares just below 2**31) the sums are exact; one more and it
    # says no
    win = 2 * radius + 1
    top = int(np.sqrt((2**31 - 1) / win**2))
    while win * win * top * top >= 2**31:
        top -= 1
    assert win * win * (top + 1) ** 2 >= 2**31
    assert divide_bands._narrow_sums(top, top, radius)
    assert not divide_bands._narrow_sums(top + 1, top, radius)
    assert not divide_bands._narrow_sums(top, top + 1, radius)
    assert not divide_bands._narrow_sums(-1, 0, radius)
    assert not divide_bands._narrow_sums(2**40, 2**40, radius)  # no int64 overflow
    forms = [ssd_in_form(f) for f in (simd.SSD_SHORT, simd.SSD_WIDE)]
    width = win + 9
    rng = np.random.default_rng(70 + radius)
    for fill in ("full", "mixed"):
        left = np.zeros((win + 2, width), dtype=np.int32)
        right = np.full((win + 2, width), top, dtype=np.int32)
        if fill == "mixed":
            right[rng.random(right.shape) < 0.3] = 0
        for y, x, j in ((0, 0, 0), (2, 3, 9), (1, 9, 4)):
            expected = numpy_window_sums(left, right, y, x, j, win)
            for form in forms:
                assert tuple(form(left, right, y, x, j, radius)) == expected
        if fill == "full":
            # the sums at the bound: one more in the signal would pass 2**31
            assert expected[0] == expected[2] == win * win * top * top
            assert expected[2] + win * win * (2 * top + 1) >= 2**31


def _transposer(n):
    """Compiled: transpose an ``n x n`` int32 block in place with ``_transpose_block``."""

    @intrinsic
    def transpose(typingctx, block):
        def codegen(context, builder, sig, args):
            data = context.make_array(sig.args[0])(context, builder, args[0]).data
            vtype = ir.VectorType(ir.IntType(32), n)
            rows = [
                builder.bitcast(builder.gep(data, [ir.Constant(ir.IntType(64), r * n)]),
                                vtype.as_pointer())
                for r in range(n)
            ]  # fmt: skip
            loaded = [builder.load(p, align=4) for p in rows]  # numpy's data: 4-byte aligned
            out = simd._transpose_block(builder, loaded)
            for value, pointer in zip(out, rows, strict=True):
                builder.store(value, pointer, align=4)
            return context.get_dummy_value()

        return types.void(block), codegen

    return numba.njit(lambda block: transpose(block))


@pytest.mark.parametrize("n", [2, 4, 8, 16])
def test_transpose_block_of_any_power_of_two(n):
    # the 8 x 8 shuffles of the lanes' rows (BAND_ROWS) and the generic rounds for the
    # other sizes
    block = np.random.default_rng(n).integers(-(2**31), 2**31, (n, n)).astype(np.int32)
    got = block.copy()
    _transposer(n)(got)
    assert (got == block.T).all()


@pytest.mark.parametrize("dtype", [np.int32, np.int64])
def test_lane_signals_are_the_rows_as_lanes(dtype):
    # band_lane_signals against numpy's transposition, for padded widths below, at and
    # around multiples of R (the vector code's last block overlaps the one before), rows
    # in any order and repeated; int32 runs the vector code, int64 the loop
    rng = np.random.default_rng(31)
    nr = simd.BAND_ROWS
    for width_p in list(range(1, 3 * nr + 2)) + [437, 438, 450]:
        height, nt = int(rng.integers(1, 12)), int(rng.integers(1, 4))
        left_p = rng.integers(-(2**31), 2**31, (height, width_p)).astype(dtype)
        right_p = rng.integers(-(2**31), 2**31, (height, width_p)).astype(dtype)
        rows = rng.integers(0, height, nt * nr).astype(np.int64)
        left_t = np.full(nt * width_p * nr + 5, 7, dtype=dtype)  # 5 past the end: untouched
        right_t = left_t.copy()
        band_costs.band_lane_signals(left_p, right_p, rows, nt, left_t, right_t)
        lanes = rows.reshape(nt, nr)
        expected_left = left_p[lanes].transpose(0, 2, 1)  # (t, xp, r)
        expected_right = right_p[lanes][:, :, ::-1].transpose(0, 2, 1)  # stored right to left
        assert (left_t[:-5].reshape(nt, width_p, nr) == expected_left).all(), width_p
        assert (right_t[:-5].reshape(nt, width_p, nr) == expected_right).all(), width_p
        assert (left_t[-5:] == 7).all() and (right_t[-5:] == 7).all()


@pytest.mark.parametrize("seed", range(3))
def test_column_vector_code_equals_its_plain_python_twin(seed):
    # the DP cells of a column (five- and three-step) and a moved cost column: the LLVM
    # vector code against the plain-Python functions it stands for, byte for byte
    rng = np.random.default_rng(800 + seed)
    nr = simd.BAND_ROWS
    for ndisp in (1, 2, 3, 7, 16, 33):
        nk = (ndisp + 2) * nr
        k_lo = int(rng.integers(0, ndisp))
        k_hi = int(rng.integers(k_lo, ndisp))
        # small integer values (ties between the steps) and inf cells
        ring = rng.integers(0, 6, (3, nk)).astype(np.float64)
        ring[rng.random(ring.shape) < 0.15] = np.inf
        cost = rng.integers(0, 4, 3 * nk).astype(np.float64)
        cost[rng.random(cost.shape) < 0.1] = np.inf
        o_here, o_left, o_steps = np.uint64(2 * nk), np.uint64(nk), np.uint64(ndisp + 2)
        results = []
        for run in (simd_dp._cells5_chain, _compiled(simd_dp._cells5_chain)):
            cur = ring[0].copy()
            steps = np.full(3 * (ndisp + 2), 0xFFFFFFFF, dtype=np.uint32)
            run(cur, ring[1], ring[2], cost, o_here, o_left, steps, o_steps, k_lo, k_hi, 2.0, 1.0)
            results.append((cur, steps))
        for run in (simd_dp._cells3_chain, _compiled(simd_dp._cells3_chain)):
            cur = ring[0].copy()
            steps = np.full(3 * (ndisp + 2), 0xFFFFFFFF, dtype=np.uint32)
            run(cur, ring[1], cost, o_here, steps, o_steps, k_lo, k_hi, 2.0)
            results.append((cur, steps))
        for a, b in (results[:2], results[2:]):
            np.testing.assert_array_equal(a[0], b[0])
            np.testing.assert_array_equal(a[1], b[1])
            # the words of blocks k_lo + 1 .. k_hi + 1 of column 1 and nothing else written
            untouched = np.ones(a[1].size, dtype=bool)
            untouched[int(o_steps) + k_lo + 1 : int(o_steps) + k_hi + 2] = False
            assert (a[1][untouched] == 0xFFFFFFFF).all()
        width_p = int(rng.integers(3, 9))
        n = ndisp * nr
        left_t = rng.integers(0, 4081, 2 * width_p * nr).astype(np.int32)
        right_t = rng.integers(0, 4081, 2 * width_p * nr + n).astype(np.int32)
        vs = rng.integers(0, 40000, 3 * n).astype(np.int32)
        hsum = rng.integers(0, 200000, n).astype(np.int32)
        moved = []
        for run in (simd_costs._moved_costs, _compiled(simd_costs._moved_costs)):
            arrays = vs.copy(), hsum.copy(), np.full(n + 2 * nr, -1.0)
            offsets = np.uint64(nr), np.uint64(0), np.uint64(2 * n), np.uint64(0), np.uint64(nr)
            run(left_t, right_t, *arrays, *offsets, np.uint64(n), width_p)
            moved.append(arrays)
        for a, b in zip(*moved, strict=True):
            np.testing.assert_array_equal(a, b)
        assert (moved[0][2][nr:-nr] != -1.0).all() and (moved[0][2][:nr] == -1.0).all()


@pytest.mark.parametrize("seed", range(3))
def test_pinned_cells_in_the_vector_code_restart_the_column_and_block_the_e_step(seed):
    # _cells5_chain's pins (e_off, pin_k), vector code and twin, against what band_forward
    # stored before: the pinned lanes' prev2 set to inf (the e-step guard), the anchor
    # column's pinned lanes set to 0 at the anchor, occ2, 2 occ2, ... below, inf above
    rng = np.random.default_rng(820 + seed)
    for ndisp in (1, 2, 3, 7, 16, 33):
        check_pinned_cells(rng, ndisp)


def check_pinned_cells(rng, ndisp):
    nr = simd.BAND_ROWS
    run5 = simd_dp._cells5_chain
    nk = (ndisp + 2) * nr
    k_lo = int(rng.integers(0, ndisp))
    k_hi = int(rng.integers(k_lo, ndisp))
    ring = rng.integers(0, 6, (3, nk)).astype(np.float64)
    ring[rng.random(ring.shape) < 0.15] = np.inf
    ring[0, (k_hi + 2) * nr :] = np.inf  # above the range: inf, as band_forward leaves it
    cost = rng.integers(0, 4, 3 * nk).astype(np.float64)
    cost[rng.random(cost.shape) < 0.1] = np.inf
    fixed = (cost, np.uint64(2 * nk), np.uint64(nk))  # the costs, o_here, o_left
    o_steps, occ2, slant2 = np.uint64(ndisp + 2), 2.0, 1.0
    guarded = rng.random(nr) < 0.5
    e_off = np.where(guarded, np.inf, 0.0)
    pinned = rng.random(nr) < 0.5
    pin_k = np.where(pinned, rng.integers(k_lo, k_hi + 1, nr), -1).astype(np.float64)

    def cells(run, prev2, *pins, anchors=None):
        cur = ring[0].copy()
        steps = np.zeros(3 * (ndisp + 2), dtype=np.uint32)
        more = () if anchors is None else (*anchors, nr)  # written at o_pin = R
        run(cur, ring[1], prev2, *fixed, steps, o_steps, k_lo, k_hi, occ2, slant2, *pins, *more)
        return cur.reshape(ndisp + 2, nr), steps

    def anchor_values(guard):
        # band_forward's scalar form: each pinned lane's anchor by a match step (c, d, e;
        # no a, no b) and the first of them that reaches it; sentinels elsewhere
        total = np.full(3 * nr, -7.0)
        codes = np.full(3 * nr, -7, dtype=np.int64)
        cost, o_here, o_left = fixed
        prev, prev2 = ring[1], ring[2]
        for r in np.flatnonzero(pinned):
            q = (int(pin_k[r]) + 1) * nr + r
            h2 = 2.0 * cost[int(o_here) + q]
            u = h2 + cost[int(o_left) + q] + slant2
            c = prev[q] + h2
            d = prev[q + nr] + cost[int(o_here) + q + nr] + u
            e = (
                (prev2[q - nr] + e_off[r] if guard else prev2[q - nr])
                + cost[int(o_left) + q - nr]
                + u
            )
            best = min(min(c, d), e)
            total[nr + r] = best
            step = dp.STEP_E if e == best else dp.STEP_NONE
            step = dp.STEP_D if d == best else step
            codes[nr + r] = dp.STEP_C if c == best else step
        return total, codes

    def restart(values):
        out = values.copy()
        for r in np.flatnonzero(pinned):
            k_a = int(pin_k[r])
            for k in range(k_lo, k_hi + 1):
                out[k + 1, r] = (k_a - k) * occ2 if k <= k_a else np.inf
        return out

    blocked = ring[2].copy().reshape(ndisp + 2, nr)
    blocked[:, guarded] = np.inf
    guarded_values, guarded_steps = cells(run5, blocked.ravel())
    free_values = cells(run5, ring[2].copy())[0]
    for pins, want in (
        ((e_off, None), guarded_values),
        ((None, pin_k), restart(free_values)),
        ((e_off, pin_k), restart(guarded_values)),
    ):
        for run in (run5, _compiled(run5)):
            if pins[1] is None:
                values, steps = cells(run, ring[2].copy(), *pins)
                # the guard alone: the steps of prev2 at inf, too
                np.testing.assert_array_equal(steps, guarded_steps)
            else:  # the pinned lanes' anchor values and steps, the others' untouched
                anchors = np.full(3 * nr, -7.0), np.full(3 * nr, -7, dtype=np.int64)
                values, steps = cells(run, ring[2].copy(), *pins, anchors=anchors)
                expected = anchor_values(pins[0] is not None)
                np.testing.assert_array_equal(anchors[0], expected[0])
                np.testing.assert_array_equal(anchors[1], expected[1])
            np.testing.assert_array_equal(values, want)


def check_moved_costs_keyed(ndisp, left_t, right_t, vs, hsum, width_p):
    """``_moved_costs_keyed`` (twin and vector code) against ``_moved_costs`` and the naive
    block match of the column it made; nothing outside the column's ``R`` matches written."""
    nr = simd.BAND_ROWS
    n = ndisp * nr
    shift = band_costs._key_shift(ndisp + 2)
    offsets = np.uint64(nr), np.uint64(0), np.uint64(2 * n), np.uint64(0), np.uint64(nr)
    plain = vs.copy(), hsum.copy(), np.full(n + 2 * nr, -1.0)
    simd_costs._moved_costs(left_t, right_t, *plain, *offsets, np.uint64(n), width_p)
    column = plain[2][nr : nr + n].reshape(ndisp, nr)
    assert (column >= 0).all() and ((column + 1) * 2**shift < 2**31).all()  # the keys fit
    expected_k, expected_ratio = naive.naive_block_match(column)
    compiled = _compiled(simd_costs._moved_costs_keyed)
    for run in (simd_costs._moved_costs_keyed, compiled):
        arrays = vs.copy(), hsum.copy(), np.full(n + 2 * nr, -1.0)
        wta_k = np.full(3 * nr, 99, dtype=np.int64)
        wta_ratio = np.full(3 * nr, -5.0)
        run(left_t, right_t, *arrays, *offsets, np.uint64(n), width_p, shift, wta_k, wta_ratio,
            np.uint64(nr))  # fmt: skip
        for a, b in zip(arrays, plain, strict=True):
            assert a.tobytes() == b.tobytes()
        assert list(wta_k[nr : 2 * nr]) == expected_k
        np.testing.assert_array_equal(wta_ratio[nr : 2 * nr], expected_ratio)
        assert (wta_k[:nr] == 99).all() and (wta_k[2 * nr :] == 99).all()
        assert (wta_ratio[:nr] == -5.0).all() and (wta_ratio[2 * nr :] == -5.0).all()
    return column


@pytest.mark.parametrize("seed", range(3))
def test_moved_costs_keyed_makes_the_costs_and_their_block_match(seed):
    # the cost pass's column made and matched at once (keys (h << shift) | (k + 1) in 32
    # bits, the four least kept per lane): the costs of _moved_costs and the block match of
    # band_block_match, on costs of the matching signal's size, on few values (ties and
    # zeros) and on costs whose keys come within a few units of 2**31; fewer than four
    # disparities too (the four least then hold "none")
    rng = np.random.default_rng(830 + seed)
    nr = simd.BAND_ROWS
    zeros = ties = near = 0
    for ndisp in (1, 2, 3, 4, 5, 7, 16, 33, 62):
        n = ndisp * nr
        shift = band_costs._key_shift(ndisp + 2)
        assert 2**shift > ndisp + 2 >= 2 ** (shift - 1)  # as _key_scale's scale
        width_p = int(rng.integers(3, 9))
        # the matching signal: costs up to some 2**18, all different
        left_t = rng.integers(0, 4081, 2 * width_p * nr).astype(np.int32)
        right_t = rng.integers(0, 4081, 2 * width_p * nr + n).astype(np.int32)
        vs = rng.integers(0, 40000, 3 * n).astype(np.int32)
        hsum = rng.integers(40000, 200000, n).astype(np.int32)
        check_moved_costs_keyed(ndisp, left_t, right_t, vs, hsum, width_p)
        # equal signals, few sums: ties, zero costs (ratio inf or 1) and equal neighbours
        flat = np.zeros(2 * width_p * nr + n, dtype=np.int32)
        vs = (rng.integers(0, 3, 3 * n) * 5).astype(np.int32)
        vs[:n] = 0  # the leaving column (o_sub 0): h = hsum + the entering one (o_add 2n)
        hsum = (rng.integers(0, 2, n) * 5).astype(np.int32)
        column = check_moved_costs_keyed(ndisp, flat[:-n], flat, vs, hsum, width_p)
        zeros += (column == 0).sum()
        ties += sum(len(set(lane)) < ndisp for lane in column.T)
        # the largest costs whose keys fit: (h + 1) << shift just below 2**31
        # (the entering sums add up to 10)
        hsum = ((2**31 >> shift) - 12 - rng.integers(0, 10, n) * 5).astype(np.int32)
        column = check_moved_costs_keyed(ndisp, flat[:-n], flat, vs, hsum, width_p)
        near += (column + 1 >= (2**31 >> shift) - 2).sum()
    assert zeros > 0 and ties > 0 and near > 0


@pytest.mark.parametrize("seed", range(3))
def test_rgb_pixels_vector_code_equals_its_twin(seed):
    # eight RGB pixels of a row to the int32 matching signal: the vector form (8 pixels'
    # 24 bytes, the channels by shuffles) against the plain one, at any offset in a row, at
    # its last pixels, with the luma weights and others
    rng = np.random.default_rng(60 + seed)
    compiled = _compiled(simd._rgb_pixels)
    lanes = simd._LANES
    for width in (lanes, lanes + 1, 21, 64):
        image = rng.integers(0, 256, (3, width, 3), dtype=np.uint8)
        image[0, :2] = [[0, 0, 0], [255, 255, 255]]  # the extremes
        for weights in (signal.LUMA, (0.25, 0.5, 0.25), (1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0)):
            for steps in (1, 16):
                for y, x0 in (
                    (0, 0),
                    (1, width - lanes),
                    (2, int(rng.integers(0, width - lanes + 1))),
                ):
                    outs = [np.full((4, width + 6), -7, dtype=np.int32) for _ in range(2)]
                    for run, out in zip((simd._rgb_pixels, compiled), outs, strict=True):
                        run(image, y, x0, weights, steps, out, y + 1, 3 + x0)
                    np.testing.assert_array_equal(outs[1], outs[0])
                    written = outs[0][y + 1, 3 + x0 : 3 + x0 + lanes]
                    assert (written != -7).all()
                    assert (np.delete(outs[0].ravel(), np.arange(lanes) + (y + 1) * (width + 6)
                                      + 3 + x0) == -7).all()  # fmt: skip


def test_address_compiled_is_the_data_pointer():
    # _address from compiled code (an intrinsic: ctypes would keep its callers out of the
    # cache) against numpy's ctypes.data
    compiled = _compiled(simd._address)
    for dtype in (np.uint8, np.int32, np.float64):
        arr = np.empty(37, dtype=dtype)
        for view in (arr, arr[5:]):
            assert compiled(view) == simd._address(view) == view.ctypes.data


def test_cycle_counter_compiled_counts_up():
    # the processor's counter from compiled code, and its plain stand-in (nanoseconds):
    # both increase across a wait
    compiled = _compiled(simd.cycle_counter)
    for read in (simd.cycle_counter, compiled):
        first = read()
        time.sleep(0.01)
        assert read() > first
