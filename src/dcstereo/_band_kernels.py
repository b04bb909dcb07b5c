"""Band kernels: the dsi3 / dsi5 scanline DPs of ``BAND_ROWS`` scanlines in lockstep.

The per-row kernels of ``_kernels.py`` loop over the disparity axis ``k`` (16..256
cells); the compiler's vector loops step 32 or more cells at a time, so most of a row
runs in their scalar remainder, and the b-step chain down a column is one sequential
chain per row. Here ``BAND_ROWS`` rows run together with the row as the innermost,
contiguous axis: the costs of a band and the steps its DP takes are
``[x, (k + 1) * BAND_ROWS + r]`` (cell ``k`` of row ``r`` of the band; one padding cell on
each side of the band, inf), and every per-cell operation, the b-chain included (it is
independent across rows), is one vector operation over the rows. The forward pass keeps
the values of the last three columns only and records, per cell, which steps reach its
value; backtracking stays per row and follows those records.

The results are *bitwise* those of ``_kernels.match_dsi_rows`` (SAD cost): every cell is
computed by the same float64 expression, in the same order of operations, as in
``_kernels.scanline_dp``, and the step recorded for it is the first of c, d, e, a, b
(``scanline_dp``'s backtrack's order of preference) whose value equals the cell's. The
padding cells replace ``scanline_dp``'s bounds-checked slow cells: a step that would read
outside the band reads inf, and ``min`` with inf changes nothing.

Anchors: a row may be pinned at pairs ``x <-> j`` (``partner``), and then its result is
that of running ``scanline_dp`` segment by segment, free start -> first anchor -> ... ->
last anchor -> free end, as ``_kernels.gcp_row`` does, in one pass over the row: at an
anchor column the match-step value of the anchor cell is kept as that segment's total,
the column is cleared and the anchor cell set to 0 (the anchored start of the next
segment; the b-chain then fills the cells below it, and their recorded step is b), the
e step from the column before the anchor to the column after it reads inf, and the
virtual start cells (``j = -1``) are off after the first anchor. Cells outside the next
segment's rectangle then hold either inf (``j`` below the anchor's) or values that no cell
of the segment reads (``j`` beyond the segment's end: steps never decrease ``j``, and the
next anchor column clears them).

The rows of a band are not consecutive: in each parallel chunk, band row ``r`` runs down
its own run of consecutive rows (``match_band_rows``), so that the integer vertical window
sums of each lane are moved down one row per band (add the entering row, subtract the
leaving one) instead of being summed afresh from the ``2 radius + 1`` window rows.

Kernels that call each other live in this one file (numba's cache does not notice edits
made in other files); nothing here is imported from ``_kernels.py``.
"""

import time

import numba as nb
import numpy as np
from llvmlite import binding as llvm
from llvmlite import ir
from numba.core import cgutils, config, types
from numba.extending import intrinsic, overload

#: Rows of a band: eight float64 values fill one AVX-512 vector. A module constant, not an
#: argument, on purpose: the compiler must see the trip count of the innermost loops to
#: turn each of them into whole vector operations without a remainder loop.
BAND_ROWS = 8

# Step codes and reason flags: the values of ``_kernels.py`` and ``result.py``.
STEP_NONE = 0
STEP_C = 1
STEP_A = 2
STEP_B = 3
STEP_D = 4
STEP_E = 5
FLAG_OCCLUDED = 1
FLAG_BORDER = 2


# --------------------------------------------------------------------------- scratch
#
# Where each scratch array of ``match_band_rows`` starts within a 4 KiB page is chosen,
# not left to the allocator. The core guesses whether a load depends on an earlier store
# from the low 12 bits of the two addresses, so arrays that start at the same offset in a
# page and are read and written with the same index in one loop (the DP's column ring,
# the cost column, the vertical sums, the spread signal) stall on false dependencies. The
# allocator's offsets depend on what was allocated before, so the same call ran at
# different speeds in different processes and threads. On the 6-megapixel pair (dsi5,
# 2 threads) the worker thread's ring rows fell on the offsets of the spread signal, the
# vertical sums and their running sum: its half of the work took 1.7 s against the main
# thread's 1.3 s. Every array on one offset made a strip 3000 x 256 x 256 16 % slower and
# tsukuba 17 % (A/B in one process).

#: Bytes between the page offsets of consecutive scratch arrays (7 cache lines: 7 and 64
#: are coprime, so 64 arrays get 64 different lines).
PLACE_STEP = 448
_PAGE = 4096


def _address(arr):
    """Return the address of ``arr``'s first element, an unsigned integer."""
    return np.uint64(arr.ctypes.data)


@intrinsic
def _data_pointer(typingctx, arr):
    def codegen(context, builder, signature, args):
        ary = context.make_array(signature.args[0])(context, builder, args[0])
        return builder.ptrtoint(ary.data, context.get_value_type(types.uintp))

    return types.uintp(arr), codegen


@overload(_address)
def _address_compiled(arr):
    # ``arr.ctypes`` would keep the calling functions out of numba's cache
    return lambda arr: _data_pointer(arr)


@nb.njit(cache=True, inline="always")
def _placed(n, dtype, slot):
    """Return an uninitialised 1-d array of ``n`` values at ``slot * PLACE_STEP`` in a page.

    ``slot * PLACE_STEP % 4096`` bytes past the start of a page; ``n + 4096`` values are
    allocated for it.
    """
    buf = np.empty(n + _PAGE, dtype=dtype)
    page = np.uint64(_PAGE)
    shift = (np.uint64(slot * PLACE_STEP % _PAGE) + page - _address(buf) % page) % page
    start = shift // np.uint64(buf.itemsize)
    return buf[start : start + n]


# --------------------------------------------------------------------------- vector code
#
# Where numba's loop vectorizer cannot express a loop well, it is written as LLVM vector
# code: values of ``BAND_ROWS`` lanes as one ``<R x double>`` (an intrinsic builds the IR;
# numba compiles and caches it with its callers). Each such function is a plain-Python
# function, run as such under ``NUMBA_DISABLE_JIT`` and held by the tests to the same
# results as its vector form, which ``overload`` gives compiled code.

_VEC_F64 = ir.VectorType(ir.DoubleType(), BAND_ROWS)
_VEC_I64 = ir.VectorType(ir.IntType(64), BAND_ROWS)
_VEC_I32 = ir.VectorType(ir.IntType(32), BAND_ROWS)
_I64 = ir.IntType(64)
_FLOOR = f"llvm.floor.v{BAND_ROWS}f64"
_FMA = f"llvm.fma.v{BAND_ROWS}f64"


def _vector_of(value, vtype):
    return ir.Constant(vtype, [value] * BAND_ROWS)


def _broadcast(builder, value, vtype):
    undef = ir.Constant(vtype, ir.Undefined)
    first = builder.insert_element(undef, value, ir.Constant(ir.IntType(32), 0))
    lanes = ir.Constant(ir.VectorType(ir.IntType(32), BAND_ROWS), [0] * BAND_ROWS)
    return builder.shuffle_vector(first, undef, lanes)


def _vector_call(builder, name, *values):
    signature = ir.FunctionType(_VEC_F64, [_VEC_F64] * len(values))
    return builder.call(cgutils.get_or_insert_function(builder.module, signature, name), values)


def _vector_min(builder, a, b):
    # a < b ? a : b: the value of numba's min for these operands (no NaN), one vminpd
    return builder.select(builder.fcmp_ordered("<", a, b), a, b)


def _words(*values):
    # the offsets and counts of the vector code: 64-bit integers, as its IR takes them
    return all(isinstance(v, types.Integer) and v.bitwidth == 64 for v in values)


def _contiguous(array, dtype, ndim=1):
    return (
        isinstance(array, types.Array)
        and array.ndim == ndim
        and array.layout == "C"
        and (array.dtype == dtype)
    )


def _array_data(context, builder, sig, args, i):
    """Return the data pointer of argument ``i`` of an intrinsic (an array)."""
    return context.make_array(sig.args[i])(context, builder, args[i]).data


def _element_bytes(vtype):
    element = vtype.element
    return 8 if isinstance(element, ir.DoubleType) else element.width // 8


def _load_vector(builder, data, index, vtype=_VEC_F64):
    """Load the ``R`` values of ``data`` (a pointer to ``vtype``'s elements) at ``index``."""
    pointer = builder.bitcast(builder.gep(data, [index]), vtype.as_pointer())
    return builder.load(pointer, align=_element_bytes(vtype))


def _store_vector(builder, value, data, index):
    """Store the vector ``value`` into ``data`` (a pointer to its elements) at ``index``."""
    pointer = builder.bitcast(builder.gep(data, [index]), value.type.as_pointer())
    builder.store(value, pointer, align=_element_bytes(value.type))


# --------------------------------------------------------------------------- costs
#
# Every hot loop below is one flat loop over unsigned indices: numba wraps a negative
# signed index around (a select per access, which turns vector loads into gathers), and
# it leaves LLVM's SLP vectorizer off, so a fixed inner loop over the ``R`` rows would be
# unrolled into scalar code. A flat loop over ``(k, r)`` is vectorized like any other.


@nb.njit(cache=True)
def band_lane_signals(left_p, right_p, rows, nt, left_t, right_t):
    """Rearrange padded rows of the two views for ``band_lane_costs``.

    Window row ``t`` (``t < nt``) of band row (lane) ``r`` is padded row ``rows[t * R + r]``:
    ``left_t[(t * wp + xp) * R + r]`` is its padded pixel ``xp`` and
    ``right_t[(t * wp + wp - 1 - xp) * R + r]`` the right one, stored right to left, so
    that the disparities of a left pixel run forward in memory.
    """
    width_p = left_p.shape[1]
    nr = BAND_ROWS
    for t in range(nt):
        _lane_rows_copy(left_p, rows, t * nr, left_t, t * width_p * nr, False)
        _lane_rows_copy(right_p, rows, t * nr, right_t, t * width_p * nr, True)


def _lane_rows_copy(src, rows, o_rows, dst, o_dst, reverse):
    """``dst[o_dst + q * R + r] = src[rows[o_rows + r], xp]``: ``R`` rows as the lanes.

    ``q = xp``, or ``wp - 1 - xp`` with ``reverse``. Compiled code runs
    ``_lane_rows_forward`` or ``_lane_rows_reversed`` for int32 signals at least ``R``
    pixels wide (vector code, the same values).
    """
    width_p = src.shape[1]
    nr = BAND_ROWS
    for r in range(nr):
        y = rows[o_rows + r]
        for xp in range(width_p):
            q = width_p - 1 - xp if reverse else xp
            dst[o_dst + q * nr + r] = src[y, xp]


_lane_rows_loop = nb.njit(cache=True, inline="always")(_lane_rows_copy)


# The copy above, scalar, stores one 32-bit value 32 bytes after the last: two loads and
# two stores a pixel of the two views. The vector form loads ``R`` pixels of each of the
# ``R`` rows, transposes the ``R x R`` block in registers and stores each pixel's ``R``
# lanes as one vector. A last block that would pass the row's end is taken ``R`` pixels
# back from it instead: it stores some values twice, the same values.


def _transpose_block(builder, vectors):
    """Return the transpose of ``n`` vectors of ``n`` lanes (``vectors[r][c]`` -> ``[c][r]``).

    ``n`` (``R`` in the band kernels) is a power of two; the tests run other sizes too.
    """
    n = len(vectors)
    mask_type = ir.VectorType(ir.IntType(32), n)

    def shuffle(a, b, lanes):
        return builder.shuffle_vector(a, b, ir.Constant(mask_type, lanes))

    if n == 8:
        # 24 shuffles that AVX2 has as single instructions (the generic rounds below cross
        # the 128-bit halves every time: 48): pairs of lanes interleaved within each half
        # (rows 2i, 2i + 1), then pairs of pairs (a column's four rows of a half), then the
        # halves exchanged
        t = []
        for i in range(0, 8, 2):
            t += [shuffle(vectors[i], vectors[i + 1], [0, 8, 1, 9, 4, 12, 5, 13]),
                  shuffle(vectors[i], vectors[i + 1], [2, 10, 3, 11, 6, 14, 7, 15])]  # fmt: skip
        u = []
        for i in (0, 4):
            for a, b in ((t[i], t[i + 2]), (t[i + 1], t[i + 3])):
                u += [shuffle(a, b, [0, 1, 8, 9, 4, 5, 12, 13]),
                      shuffle(a, b, [2, 3, 10, 11, 6, 7, 14, 15])]  # fmt: skip
        # u[c] (c < 4): column c of rows 0-3 in its low half, column c + 4 in its high half
        low, high = [0, 1, 2, 3, 8, 9, 10, 11], [4, 5, 6, 7, 12, 13, 14, 15]
        return [shuffle(u[c % 4], u[c % 4 + 4], low if c < 4 else high) for c in range(8)]
    # any other n: log2 n rounds of interleaving rows i and i + n / 2, each of which
    # rotates the bits of a value's (row, column) index by one place
    half = n // 2
    low = [i // 2 + (n if i % 2 else 0) for i in range(n)]
    high = [half + i // 2 + (n if i % 2 else 0) for i in range(n)]
    for _ in range(n.bit_length() - 1):
        out = []
        for i in range(half):
            out.append(shuffle(vectors[i], vectors[i + half], low))
            out.append(shuffle(vectors[i], vectors[i + half], high))
        vectors = out
    return vectors


def _lane_rows_codegen(reverse):
    def codegen(context, builder, sig, args):
        _, _, o_rows, _, o_dst = args
        source = context.make_array(sig.args[0])(context, builder, args[0])
        width_p = cgutils.unpack_tuple(builder, source.shape, 2)[1]
        rows = _array_data(context, builder, sig, args, 1)
        dst = _array_data(context, builder, sig, args, 3)
        nr = ir.Constant(_I64, BAND_ROWS)
        starts = []  # the first pixel of each lane's row
        for r in range(BAND_ROWS):
            y = builder.load(builder.gep(rows, [builder.add(o_rows, ir.Constant(_I64, r))]))
            starts.append(builder.gep(source.data, [builder.mul(y, width_p)]))
        last = builder.sub(width_p, nr)
        blocks = builder.udiv(builder.add(width_p, ir.Constant(_I64, BAND_ROWS - 1)), nr)
        with cgutils.for_range(builder, blocks) as loop:
            xp = builder.mul(loop.index, nr)
            xp = builder.select(builder.icmp_unsigned(">", xp, last), last, xp)
            loaded = [_load_vector(builder, start, xp, _VEC_I32) for start in starts]
            for c, lanes in enumerate(_transpose_block(builder, loaded)):
                q = builder.add(xp, ir.Constant(_I64, c))
                if reverse:
                    q = builder.sub(builder.sub(width_p, ir.Constant(_I64, 1)), q)
                _store_vector(builder, lanes, dst, builder.add(o_dst, builder.mul(q, nr)))
        return context.get_dummy_value()

    return codegen


def _lane_rows_intrinsic(reverse):
    @intrinsic
    def vector(typingctx, src, rows, o_rows, dst, o_dst):
        if not (
            _contiguous(src, types.int32, 2)
            and _contiguous(rows, types.int64)
            and _contiguous(dst, types.int32)
            and _words(o_rows, o_dst)
        ):
            return None
        return types.void(src, rows, o_rows, dst, o_dst), _lane_rows_codegen(reverse)

    return vector


_lane_rows_forward = _lane_rows_intrinsic(False)
_lane_rows_reversed = _lane_rows_intrinsic(True)


@overload(_lane_rows_copy)
def _lane_rows_compiled(src, rows, o_rows, dst, o_dst, reverse):
    if not (
        _contiguous(src, types.int32, 2)
        and _contiguous(rows, types.int64)
        and _contiguous(dst, types.int32)
    ):
        return _lane_rows_copy  # other signals (the tests' int64 buffers): the loop

    def run(src, rows, o_rows, dst, o_dst, reverse):
        if src.shape[1] < BAND_ROWS:
            _lane_rows_loop(src, rows, o_rows, dst, o_dst, reverse)
        elif reverse:
            _lane_rows_reversed(src, rows, np.int64(o_rows), dst, np.int64(o_dst))
        else:
            _lane_rows_forward(src, rows, np.int64(o_rows), dst, np.int64(o_dst))

    return run


@nb.njit(cache=True, inline="always")
def _spread(left_t, o_left, spread, o_spread, n):
    """``spread[o_spread + i]``, ``i < n``: the ``R`` values at ``left_t[o_left]``, repeated."""
    nr = BAND_ROWS
    for r in range(nr):
        spread[o_spread + r] = left_t[o_left + r]
    # one flat loop, a copy from 8 cells back: the compiler's vector loop keeps the R
    # values in one register and stores it n / R times (the doubling copies this replaced
    # were several short loops per column, a fifth of the cost computation on tsukuba)
    for i in range(np.uint64(nr), n):
        spread[o_spread + i] = spread[o_spread + i - np.uint64(nr)]


# _vertical_sums and _vertical_update are compiled functions of their own, not inlined into
# numba's IR as the small helpers are: every inlined call site copies the callee's IR and
# types it again, and these two sit under _column_sums, which sits under three call sites
# of _cost_column, itself inlined in three kernels. Inlined, that tree was half of
# ``dc``'s first compile (117 s -> 60 s without it on the AMD host, docs/SPEED.md). Called,
# ``block``, ``dsi3`` and ``dsi5`` kept their times; ``dc`` and ``dsi3-gcp`` measured 1-4 %
# slower, at the edge of the noise (each call makes or moves a whole column's sums).
@nb.njit(cache=True)
def _vertical_sums(left_t, right_t, c, width, width_p, dmin, ndisp, radius, spread, vs, vs_off):
    """Vertical window SADs of left column ``c`` into ``vs[vs_off + k * R + r]``.

    Disparity ``dmin + k``, band row ``r``; 0 where the right pixel is outside the image.

    ``spread`` (int64, ``2 * ndisp * R``) is scratch: the left pixel's ``R`` values of a
    window row repeated along the disparities, so that the inner loops read both views
    contiguously. Window rows are taken two at a time (one pass over ``vs`` per two).
    """
    nr = BAND_ROWS
    win = 2 * radius + 1
    k_lo = max(0, c - dmin - (width - 1))
    k_hi = min(ndisp - 1, c - dmin)
    if k_lo > k_hi:
        for i in range(np.uint64(ndisp * nr)):
            vs[vs_off + i] = 0
        return
    for i in range(np.uint64(k_lo * nr)):
        vs[vs_off + i] = 0
    for i in range(np.uint64((k_hi + 1) * nr), np.uint64(ndisp * nr)):
        vs[vs_off + i] = 0
    n = np.uint64((k_hi - k_lo + 1) * nr)
    o_vs = vs_off + np.uint64(k_lo * nr)
    o_left = (width_p + c + radius) * nr  # window row 1; row t is (t - 1) * width_p * nr on
    o_right = np.uint64((width_p + width_p - 1 - (c - dmin - k_lo + radius)) * nr)
    step = np.uint64(width_p * nr)
    _spread(left_t, o_left - width_p * nr, spread, np.uint64(0), n)
    if win == 1:
        for i in range(n):
            vs[o_vs + i] = abs(spread[i] - right_t[o_right - step + i])
        return
    _spread(left_t, o_left, spread, n, n)
    for i in range(n):
        vs[o_vs + i] = abs(spread[i] - right_t[o_right - step + i]) + abs(
            spread[n + i] - right_t[o_right + i]
        )
    for t in range(2, win, 2):
        o_l = o_left + (t - 1) * width_p * nr
        o_r = o_right + np.uint64(t - 1) * step
        _spread(left_t, o_l, spread, np.uint64(0), n)
        if t + 1 == win:
            for i in range(n):
                vs[o_vs + i] += abs(spread[i] - right_t[o_r + i])
        else:
            _spread(left_t, o_l + width_p * nr, spread, n, n)
            for i in range(n):
                vs[o_vs + i] += abs(spread[i] - right_t[o_r + i]) + abs(
                    spread[n + i] - right_t[o_r + step + i]
                )


@nb.njit(cache=True)
def _vertical_update(left_t, right_t, c, width, width_p, dmin, ndisp, radius, spread, vs, vs_off):
    """Move the vertical window SADs of column ``c`` at ``vs[vs_off + k * R + r]`` down a row.

    ``left_t``/``right_t`` hold two rows per lane (``band_lane_signals``): row 0 the
    padded row leaving each lane's window, row 1 the one entering it; the sums gain the
    entering row's absolute differences and lose the leaving row's (two per cell instead
    of ``2 radius + 1``; exact integers). Cells whose right pixel is outside the image are
    not touched (they hold 0 from the full computation).
    """
    nr = BAND_ROWS
    k_lo = max(0, c - dmin - (width - 1))
    k_hi = min(ndisp - 1, c - dmin)
    if k_lo > k_hi:
        return
    n = np.uint64((k_hi - k_lo + 1) * nr)
    o_vs = vs_off + np.uint64(k_lo * nr)
    o_leave = (c + radius) * nr
    o_r_leave = np.uint64((width_p - 1 - (c - dmin - k_lo + radius)) * nr)
    o_r_enter = o_r_leave + np.uint64(width_p * nr)
    _spread(left_t, o_leave + width_p * nr, spread, np.uint64(0), n)
    _spread(left_t, o_leave, spread, n, n)
    for i in range(n):
        vs[o_vs + i] += abs(spread[i] - right_t[o_r_enter + i]) - abs(
            spread[n + i] - right_t[o_r_leave + i]
        )


#: ``incremental`` of the cost passes when an earlier pass over the same band has already
#: made the vertical sums (False: afresh; True: moved down a row; see ``band_lane_costs``).
SUMS_READY = 2


@nb.njit(cache=True, inline="always")
def _column_sums(left_t, right_t, c, width, width_p, dmin, ndisp, radius, spread, vs, incremental):
    """Vertical window sums of column ``c`` (afresh, moved down a row, or ready); their offset."""
    offset = np.uint64(c * ndisp * BAND_ROWS)
    if incremental == SUMS_READY:
        return offset
    if incremental:
        _vertical_update(
            left_t, right_t, c, width, width_p, dmin, ndisp, radius, spread, vs, offset
        )
    else:
        _vertical_sums(left_t, right_t, c, width, width_p, dmin, ndisp, radius, spread, vs, offset)
    return offset


def _moved_costs(left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub, o_out, n, width_p):
    """One bulk column of the cost passes, its vertical sums moved down a row (``n`` cells).

    The fused form of ``_vertical_update`` for a column ``add`` whose every disparity has
    its right pixel inside the image, then the running horizontal sum: ``vs[o_add + i]``
    gains the entering rows' absolute difference and loses the leaving rows' (the left
    pixels of lane ``r`` at ``left_t[o_left + r]``, leaving, and ``width_p * R`` further,
    entering; the right ones at ``right_t[o_right + i]`` and ``width_p * R`` further), then
    ``hsum[i]`` gains it and loses ``vs[o_sub + i]``, and ``out[o_out + i]`` is the new
    ``hsum[i]`` as float64. Exact integers throughout (int32, as the arrays). Compiled code
    runs ``_moved_costs_vector`` (a block of ``R`` cells at a time, the left pixels in a
    register instead of ``_spread`` copies).
    """
    nr = BAND_ROWS
    step = np.uint64(width_p * nr)
    for i in range(np.uint64(n)):
        r = i % np.uint64(nr)
        enter = left_t[o_left + step + r]
        leave = left_t[o_left + r]
        vs[o_add + i] += abs(enter - right_t[o_right + step + i]) - abs(
            leave - right_t[o_right + i]
        )
        h = np.int32(hsum[i] + (vs[o_add + i] - vs[o_sub + i]))
        hsum[i] = h
        out[o_out + i] = h


def _moved_costs_keyed(left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub, o_out, n,
                       width_p, shift, wta_k, wta_ratio, i0):  # fmt: skip
    """``_moved_costs``, then the block match of the column it made, for ``band_lane_costs``.

    The column's ``n / R`` disparities are blocks ``j = k + 1``; lane ``r``'s key of block
    ``j`` is ``(h << shift) | j`` (``h`` its cost, ``2**shift`` above the blocks), an
    integer ordered as ``(h, j)``. ``wta_k[i0 + r]`` and ``wta_ratio[i0 + r]`` get the
    values of ``band_block_match`` on the column: the block of the least key, and the
    least cost over ``|j - b| >= 2`` over the least (no such block: inf). The caller
    ensures that every key is below ``2**31 - 1`` (``_keys_fit``). Compiled code runs
    ``_moved_costs_keyed_vector``: the keys in 32-bit lanes, kept as the four least of
    each lane while the costs are made, the column never read back.
    """
    _moved_costs(left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub, o_out, n, width_p)
    nr = BAND_ROWS
    nblocks = np.uint64(n) // np.uint64(nr)
    for r in range(nr):
        least = 2**63 - 1
        for k in range(nblocks):
            h = np.int64(out[o_out + k * np.uint64(nr) + r])
            least = min(least, (h << shift) | np.int64(k + 1))
        b = least & ((1 << shift) - 1)
        second = np.inf
        for k in range(nblocks):
            if abs(np.int64(k + 1) - b) >= 2:
                second = min(second, out[o_out + k * np.uint64(nr) + r])
        best = float(least >> shift)
        wta_k[i0 + r] = b - 1
        if best > 0:
            wta_ratio[i0 + r] = second / best
        else:
            wta_ratio[i0 + r] = np.inf if second > 0 else 1.0


@nb.njit(cache=True, inline="always")
def _keys_fit(span, radius, shift):
    """Whether ``_moved_costs_keyed``'s keys fit: ``(h + 1) << shift < 2**31`` for every cost.

    ``span`` bounds the absolute difference of two signal values; a cost is a window of
    ``(2 radius + 1)**2`` of them.
    """
    win = 2 * radius + 1
    # (h + 1) << shift < 2**31 as h + 1 < 2**(31 - shift), which cannot overflow
    return 0 <= span and shift < 31 and span * win * win + 1 < np.int64(1) << (31 - shift)


@nb.njit(cache=True, inline="always")
def _key_shift(nblocks):
    """Return ``shift``: ``2**shift`` is the least power of two above ``nblocks``.

    The keys' scale, as a shift for the integer keys (``_moved_costs_keyed``) and as a
    float64 for the others (``_key_scale``).
    """
    shift = 0
    while (1 << shift) <= nblocks:
        shift += 1
    return shift


def _moved_costs_codegen(keyed):
    """Return the vector code of ``_moved_costs`` (``keyed``: of ``_moved_costs_keyed``)."""

    def codegen(context, builder, sig, args):
        left, right, sums, running, costs = (
            _array_data(context, builder, sig, args, i) for i in range(5)
        )
        o_left, o_right, o_add, o_sub, o_out, n, width_p = args[5:12]
        step = builder.mul(width_p, ir.Constant(_I64, BAND_ROWS))
        no_poison = ir.Constant(ir.IntType(1), 0)
        abs32 = cgutils.get_or_insert_function(
            builder.module,
            ir.FunctionType(_VEC_I32, [_VEC_I32, ir.IntType(1)]),
            f"llvm.abs.v{BAND_ROWS}i32",
        )

        def load(array, index):
            return _load_vector(builder, array, index, _VEC_I32)

        def dist(a, b):
            return builder.call(abs32, [builder.sub(a, b), no_poison])

        def signed(op, a, b):  # the signed minimum or maximum of two int32 vectors
            return builder.select(builder.icmp_signed(op, a, b), a, b)

        if keyed:
            # the four least keys of each lane, in order (an insertion: min and max down
            # the four), and the next block's number; "none" is above every key
            shift = _broadcast(builder, builder.trunc(args[12], ir.IntType(32)), _VEC_I32)
            none = _vector_of(2**31 - 1, _VEC_I32)
            least = [cgutils.alloca_once_value(builder, none) for _ in range(4)]
            number = cgutils.alloca_once_value(builder, _vector_of(1, _VEC_I32))
        leave = load(left, o_left)
        enter = load(left, builder.add(o_left, step))
        blocks = builder.udiv(n, ir.Constant(_I64, BAND_ROWS))
        width = ir.Constant(_I64, BAND_ROWS)
        with cgutils.for_range(builder, blocks) as loop:
            i = builder.mul(loop.index, width)
            right_at = builder.add(o_right, i)
            moved = builder.add(
                load(sums, builder.add(o_add, i)),
                builder.sub(
                    dist(enter, load(right, builder.add(right_at, step))),
                    dist(leave, load(right, right_at)),
                ),
            )
            _store_vector(builder, moved, sums, builder.add(o_add, i))
            h = builder.add(load(running, i), builder.sub(moved, load(sums, builder.add(o_sub, i))))
            _store_vector(builder, h, running, i)
            _store_vector(builder, builder.sitofp(h, _VEC_F64), costs, builder.add(o_out, i))
            if keyed:
                j = builder.load(number)
                builder.store(builder.add(j, _vector_of(1, _VEC_I32)), number)
                key = builder.or_(builder.shl(h, shift), j)
                for place, slot in enumerate(least):
                    old = builder.load(slot)
                    builder.store(signed("<", old, key), slot)
                    if place < len(least) - 1:
                        key = signed(">", old, key)
        if not keyed:
            return context.get_dummy_value()
        # the match: the least key's block b; the second cost: the first of the next three
        # keys whose block is at least two from b (at most two of them are b's neighbours)
        keys = [builder.load(slot) for slot in least]
        low_bits = builder.sub(builder.shl(_vector_of(1, _VEC_I32), shift), _vector_of(1, _VEC_I32))
        block = builder.and_(keys[0], low_bits)
        second = none
        for key in reversed(keys[1:]):
            apart = builder.icmp_signed(
                ">=", dist(builder.and_(key, low_bits), block), _vector_of(2, _VEC_I32)
            )
            second = builder.select(builder.and_(apart, builder.icmp_signed("<", key, none)), key,
                                    second)  # fmt: skip
        inf = _vector_of(float("inf"), _VEC_F64)
        zero = _vector_of(0.0, _VEC_F64)
        best = builder.sitofp(builder.ashr(keys[0], shift), _VEC_F64)
        second = builder.select(
            builder.icmp_signed("<", second, none),
            builder.sitofp(builder.ashr(second, shift), _VEC_F64),
            inf,
        )
        ratio = builder.select(
            builder.fcmp_ordered(">", best, zero),
            builder.fdiv(second, best),
            builder.select(builder.fcmp_ordered(">", second, zero), inf, _vector_of(1.0, _VEC_F64)),
        )
        match = builder.sub(builder.sext(block, _VEC_I64), _vector_of(1, _VEC_I64))
        _store_vector(builder, match, _array_data(context, builder, sig, args, 13), args[15])
        _store_vector(builder, ratio, _array_data(context, builder, sig, args, 14), args[15])
        return context.get_dummy_value()

    return codegen


def _moved_arguments_ok(left_t, right_t, vs, hsum, out, offsets):
    return (
        all(_contiguous(a, types.int32) for a in (left_t, right_t, vs, hsum))
        and _contiguous(out, types.float64)
        and _words(*offsets)
    )


@intrinsic
def _moved_costs_vector(typingctx, left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub,
                        o_out, n, width_p):  # fmt: skip
    offsets = (o_left, o_right, o_add, o_sub, o_out, n, width_p)
    if not _moved_arguments_ok(left_t, right_t, vs, hsum, out, offsets):
        return None
    signature = types.void(left_t, right_t, vs, hsum, out, *offsets)
    return signature, _moved_costs_codegen(False)


@intrinsic
def _moved_costs_keyed_vector(typingctx, left_t, right_t, vs, hsum, out, o_left, o_right, o_add,
                              o_sub, o_out, n, width_p, shift, wta_k, wta_ratio, i0):  # fmt: skip
    offsets = (o_left, o_right, o_add, o_sub, o_out, n, width_p)
    if not (
        _moved_arguments_ok(left_t, right_t, vs, hsum, out, offsets + (shift, i0))
        and _contiguous(wta_k, types.int64)
        and _contiguous(wta_ratio, types.float64)
    ):
        return None
    signature = types.void(left_t, right_t, vs, hsum, out, *offsets, shift, wta_k, wta_ratio, i0)
    return signature, _moved_costs_codegen(True)


@overload(_moved_costs)
def _moved_costs_compiled(left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub, o_out, n,
                          width_p):  # fmt: skip
    if not all(_contiguous(a, types.int32) for a in (left_t, right_t, vs, hsum)):
        return _moved_costs  # other integer arrays (the tests' int64 ones): the loop

    def run(left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub, o_out, n, width_p):
        _moved_costs_vector(
            left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub, o_out, n, width_p
        )

    return run


@overload(_moved_costs_keyed)
def _moved_costs_keyed_compiled(left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub,
                                o_out, n, width_p, shift, wta_k, wta_ratio, i0):  # fmt: skip
    if not all(_contiguous(a, types.int32) for a in (left_t, right_t, vs, hsum)):
        return _moved_costs_keyed  # the tests' int64 arrays: the loops

    def run(left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub, o_out, n, width_p,
            shift, wta_k, wta_ratio, i0):  # fmt: skip
        _moved_costs_keyed_vector(
            left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub, o_out, n, width_p,
            shift, wta_k, wta_ratio, i0,
        )  # fmt: skip

    return run


@nb.njit(cache=True, inline="always")
def _movable(add, sub, width, dmin, ndisp, incremental):
    """Whether ``_moved_costs`` makes the column whose window gains ``add`` and loses ``sub``.

    Where the column's sums move down a row (``incremental`` 1), the window's entering
    column ``add`` and leaving column ``sub`` are inside the image, and every disparity of
    ``add`` has its right pixel inside the image.
    """
    return (
        incremental == 1
        and add < width
        and sub >= 0
        and add - dmin - (width - 1) <= 0
        and add - dmin >= ndisp - 1
    )


@nb.njit(cache=True, inline="always")
def _moved_offsets(add, dmin, radius, width_p, nkc):
    """Return ``_moved_costs``' ``(o_left, o_right, o_add)`` for the column that gains ``add``."""
    nr = BAND_ROWS
    o_right = np.uint64((width_p - 1 - (add - dmin + radius)) * nr)
    return np.uint64((add + radius) * nr), o_right, np.uint64(add) * nkc


@nb.njit(cache=True, inline="always")
def _moved_column(
    left_t, right_t, vs, hsum, out, add, sub, width, width_p, dmin, ndisp, radius, incremental,
    o_sub, o_out,
):  # fmt: skip
    """Make a bulk column by ``_moved_costs`` where ``_movable``; return whether it did."""
    if not _movable(add, sub, width, dmin, ndisp, incremental):
        return False
    nkc = np.uint64(ndisp * BAND_ROWS)
    o_left, o_right, o_add = _moved_offsets(add, dmin, radius, width_p, nkc)
    _moved_costs(left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub, o_out, nkc, width_p)
    return True


@nb.njit(cache=True, inline="always")
def _finish_band_costs(out, width, dmin, ndisp, radius):
    """Finish a band cost array: inf in the padding cells and outside the right image.

    Also rescales the truncated windows near the ends of each disparity's range to the
    full window (``* W / columns used``: the float64 operations of ``row_costs``).
    """
    nr = BAND_ROWS
    nk = (ndisp + 2) * nr
    inf = np.inf
    for x in range(width):
        for r in range(nr):
            out[x * nk + r] = inf
            out[x * nk + nk - nr + r] = inf
    for k in range(ndisp):
        d = dmin + k
        base = (k + 1) * nr
        x0 = max(0, d)
        x1 = min(width, width + d)  # exclusive; 0 <= x - d < width
        for x in range(0, min(x0, width)):
            for r in range(nr):
                out[x * nk + base + r] = inf
        for x in range(max(x1, 0), width):
            for r in range(nr):
                out[x * nk + base + r] = inf
        # only the first and last ``radius`` columns of the range have truncated windows
        lo_end = min(x0 + radius, x1)
        _rescale_truncated(out, x0, lo_end, x0, x1, radius, base, nk)
        _rescale_truncated(out, max(x1 - radius, lo_end), x1, x0, x1, radius, base, nk)


@nb.njit(cache=True, inline="always")
def _rescale_truncated(out, x_from, x_to, x0, x1, radius, base, nk):
    """Rescale the cells at ``base`` of columns ``x_from .. x_to - 1`` to the full window.

    A column ``x`` of the disparity's range ``x0 .. x1 - 1`` uses the window columns inside
    that range; its cost times ``W / columns used``, the float64 operations of ``row_costs``.
    """
    nr = BAND_ROWS
    win = 2 * radius + 1
    for x in range(x_from, x_to):
        used = min(x + radius, x1 - 1) - max(x - radius, x0) + 1
        if used != win:
            for r in range(nr):
                i = x * nk + base + r
                out[i] = out[i] * win / used


@nb.njit(cache=True)
def band_lane_costs(
    left_t, right_t, width, dmin, ndisp, radius, spread, vs, incremental, hsum, out, match=None
):
    """Windowed SAD of eq. 4 of a band into ``out[x * nk + (k + 1) * R + r]``.

    ``nk = (ndisp + 2) * R``; the values are those of ``row_costs``, bit for bit. ``vs``
    (``width * ndisp * R``) keeps the vertical sums of column ``c`` at ``c * ndisp * R``;
    ``hsum`` (``ndisp * R``) is their running horizontal sum. The driver keeps ``vs``,
    ``hsum``, ``left_t``, ``right_t`` and ``spread`` in int32 (half the memory traffic and
    one int32 -> float64 conversion per cell; the signals are int32, ``row_costs`` keeps
    its vertical sums in int32 too, and a window sum fits: ``MatchParams`` takes windows
    up to ``MAX_WINDOW``, whose 4080 * window**2 is below 2**31).

    ``incremental`` False: ``left_t``/``right_t`` hold the ``2 radius + 1`` window rows of
    each lane (``band_lane_signals``) and the sums are computed afresh; True: ``vs`` holds
    the sums of the rows just above each lane's row, and ``left_t``/``right_t`` the
    leaving and entering rows (see ``_vertical_update``); ``SUMS_READY``: ``vs`` already
    holds this band's sums (``band_block_match`` made its costs). The window sums are exact
    integers, so the order of summation is free. Then, as in ``row_costs``: inf where the
    right pixel is outside the image, the truncated windows near the ends of each
    disparity's range rescaled to the full window (``* W / columns used``, the same
    float64 operations), and inf in the padding cells ``k = -1`` and ``k = ndisp``.

    ``_cost_column`` makes the same values one column at a time, for the DP pass that needs
    no cost array. The two are kept apart on purpose: this form, whose column loop has no
    case for the first column and leaves the inf and rescaled cells to passes after it,
    measured 7-20 % faster for the band's array than the column form or a helper shared by
    both (both are checked against ``row_costs`` bit for bit).

    ``match`` None: the costs only. Otherwise ``(x_lo, x_hi, shift, wta_k, wta_ratio,
    done)``: the columns ``x_lo <= x < x_hi`` that ``_moved_costs`` makes (moved down a
    row, every window and disparity inside the image) are block-matched as they are made
    (``_moved_costs_keyed``, keys ``(h << shift) | (k + 1)``; the caller checks
    ``_keys_fit``), into ``wta_k`` and ``wta_ratio`` as ``band_block_match`` would, and
    ``done[x]`` is 1 for them, 0 for every other column. The range must lie inside
    ``_integer_columns``.
    """
    nr = BAND_ROWS
    width_p = width + 2 * radius
    nkc = np.uint64(ndisp * nr)
    nk = (ndisp + 2) * nr
    for i in range(nkc):
        hsum[i] = 0
    if match is not None:
        done = match[5]
        for x in range(width):
            done[x] = 0
    for c in range(min(radius, width - 1) + 1):
        o_c = _column_sums(
            left_t, right_t, c, width, width_p, dmin, ndisp, radius, spread, vs, incremental
        )
        for i in range(nkc):
            hsum[i] += vs[o_c + i]
    for i in range(nkc):
        out[np.uint64(nr) + i] = hsum[i]
    for x in range(1, width):
        add = x + radius
        sub = x - radius - 1
        o_out = np.uint64(x * nk + nr)
        o_sub = np.uint64(max(sub, 0) * nkc)
        if match is not None:
            x_lo, x_hi, shift, wta_k, wta_ratio, done = match
            if x_lo <= x < x_hi and _movable(add, sub, width, dmin, ndisp, incremental):
                # made and matched at once
                o_left, o_right, o_add = _moved_offsets(add, dmin, radius, width_p, nkc)
                _moved_costs_keyed(
                    left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub, o_out, nkc,
                    width_p, shift, wta_k, wta_ratio, np.uint64(x * nr),
                )  # fmt: skip
                done[x] = 1
                continue
        if _moved_column(
            left_t, right_t, vs, hsum, out, add, sub, width, width_p, dmin, ndisp, radius,
            incremental, o_sub, o_out,
        ):  # fmt: skip
            continue
        if add < width:
            o_add = _column_sums(
                left_t, right_t, add, width, width_p, dmin, ndisp, radius, spread, vs, incremental
            )
            if sub >= 0:  # the bulk of the row: one pass
                for i in range(nkc):
                    h = np.int32(hsum[i] + (vs[o_add + i] - vs[o_sub + i]))
                    hsum[i] = h
                    out[o_out + i] = h
                continue
            for i in range(nkc):
                hsum[i] += vs[o_add + i]
        elif sub >= 0:
            for i in range(nkc):
                hsum[i] -= vs[o_sub + i]
        for i in range(nkc):
            out[o_out + i] = hsum[i]
    _finish_band_costs(out, width, dmin, ndisp, radius)


# --------------------------------------------------------------------------- Birchfield-Tomasi


@nb.njit(cache=True, inline="always")
def _bt_cell2(l2, l_min, l_max, r2, r_min, r_max):
    """Twice the Birchfield-Tomasi dissimilarity (``_kernels._bt_cell2``, the same integers).

    In int32 throughout (numba would widen each difference to int64, halving the lanes of
    the vector loop; the doubled signals and their differences fit 32 bits).
    """
    zero = np.int32(0)
    d_lr = max(zero, max(np.int32(l2 - r_max), np.int32(r_min - l2)))
    d_rl = max(zero, max(np.int32(r2 - l_max), np.int32(l_min - r2)))
    return min(d_lr, d_rl)


@nb.njit(cache=True, inline="always")
def _bt_lane_bounds(sig_t, slot, width, radius, reverse, bounds, o_bounds):
    """Doubled values and half-pixel bounds of window row ``slot`` of every lane.

    ``sig_t`` as ``band_lane_signals`` lays a view out (``reverse``: the right view, stored
    right to left). ``bounds[o_bounds + 0/1/2]``, each ``width_p * R`` at the same places
    as the row's pixels: the doubled value and the least and largest of it and its two
    doubled half-pixel interpolations (``_kernels._bt_row_bounds``; a neighbour outside the
    image is the pixel itself), for the image's columns.
    """
    nr = BAND_ROWS
    width_p = width + 2 * radius
    lo = radius
    hi = radius + width - 1
    base = slot * width_p * nr
    v2 = bounds[o_bounds]
    v_min = bounds[o_bounds + 1]
    v_max = bounds[o_bounds + 2]
    for xp in range(lo, hi + 1):
        p = xp
        pm = max(xp - 1, lo)
        pp = min(xp + 1, hi)
        if reverse:
            p = width_p - 1 - p
            pm = width_p - 1 - pm
            pp = width_p - 1 - pp
        o = base + p * nr
        o_m = base + pm * nr
        o_p = base + pp * nr
        for r in range(nr):
            v = sig_t[o + r]
            twice = 2 * v
            minus = v + sig_t[o_m + r]
            plus = v + sig_t[o_p + r]
            v2[p * nr + r] = twice
            v_min[p * nr + r] = min(twice, min(minus, plus))
            v_max[p * nr + r] = max(twice, max(minus, plus))


@nb.njit(cache=True, inline="always")
def _bt_vertical_row(bounds, o_bounds, c, width, dmin, ndisp, radius, spread, vs, sign):
    """Add (``sign`` 1) or subtract (-1) one window row's doubled BT values to column ``c``.

    ``bounds[o_bounds:o_bounds + 3]`` the left view's, ``bounds[o_bounds + 3:o_bounds + 6]``
    the right view's (``_bt_lane_bounds``); ``vs[c * ndisp * R + k * R + r]``, only the
    disparities whose right pixel is inside the image. ``spread`` (``3 * ndisp * R``):
    the left pixel's values repeated along the disparities (see ``_spread``).
    """
    nr = BAND_ROWS
    width_p = width + 2 * radius
    k_lo = max(0, c - dmin - (width - 1))
    k_hi = min(ndisp - 1, c - dmin)
    if k_lo > k_hi:
        return
    n = np.uint64((k_hi - k_lo + 1) * nr)
    o_vs = np.uint64((c * ndisp + k_lo) * nr)
    o_left = np.uint64((c + radius) * nr)
    o_right = np.uint64((width_p - 1 - (c - dmin - k_lo + radius)) * nr)
    _spread(bounds[o_bounds], o_left, spread, np.uint64(0), n)
    _spread(bounds[o_bounds + 1], o_left, spread, n, n)
    _spread(bounds[o_bounds + 2], o_left, spread, n + n, n)
    r2 = bounds[o_bounds + 3]
    r_min = bounds[o_bounds + 4]
    r_max = bounds[o_bounds + 5]
    for i in range(n):
        j = o_right + i
        value = _bt_cell2(spread[i], spread[n + i], spread[n + n + i], r2[j], r_min[j], r_max[j])
        vs[o_vs + i] = np.int32(vs[o_vs + i] + (value if sign > 0 else -value))


@nb.njit(cache=True)
def band_lane_costs_bt(
    left_t, right_t, width, dmin, ndisp, radius, bounds, spread, vs, incremental, hsum, out
):
    """Windowed Birchfield-Tomasi dissimilarity of a band, the layout of ``band_lane_costs``.

    The values of ``_kernels.row_costs_bt``, bit for bit: the doubled dissimilarities
    summed over the window (exact integers, int32 as there), halved, then inf where the
    right pixel is outside the image and the truncated windows rescaled
    (``_finish_band_costs``). ``incremental`` as in ``band_lane_costs`` (no
    ``SUMS_READY``): False, ``left_t``/``right_t`` hold each lane's ``2 radius + 1`` window
    rows and ``vs`` is made afresh; True, the leaving and the entering row, and ``vs``
    moves down a row. ``bounds`` (``12 x width_p * R``, int32) and ``spread``
    (``3 * ndisp * R``) are scratch; ``vs`` and ``hsum`` as in ``band_lane_costs``.
    """
    nr = BAND_ROWS
    win = 2 * radius + 1
    nkc = np.uint64(ndisp * nr)
    nk = (ndisp + 2) * nr
    if incremental:
        _bt_lane_bounds(left_t, 0, width, radius, False, bounds, 0)
        _bt_lane_bounds(right_t, 0, width, radius, True, bounds, 3)
        _bt_lane_bounds(left_t, 1, width, radius, False, bounds, 6)
        _bt_lane_bounds(right_t, 1, width, radius, True, bounds, 9)
        for c in range(width):
            _bt_vertical_row(bounds, 6, c, width, dmin, ndisp, radius, spread, vs, 1)
            _bt_vertical_row(bounds, 0, c, width, dmin, ndisp, radius, spread, vs, -1)
    else:
        for i in range(np.uint64(width) * nkc):
            vs[i] = 0
        for t in range(win):
            _bt_lane_bounds(left_t, t, width, radius, False, bounds, 0)
            _bt_lane_bounds(right_t, t, width, radius, True, bounds, 3)
            for c in range(width):
                _bt_vertical_row(bounds, 0, c, width, dmin, ndisp, radius, spread, vs, 1)
    for i in range(nkc):
        hsum[i] = 0
    for c in range(min(radius, width - 1) + 1):
        o_c = np.uint64(c) * nkc
        for i in range(nkc):
            hsum[i] += vs[o_c + i]
    for x in range(width):
        if x > 0:
            add = x + radius
            sub = x - radius - 1
            if add < width:
                o_add = np.uint64(add) * nkc
                for i in range(nkc):
                    hsum[i] += vs[o_add + i]
            if sub >= 0:
                o_sub = np.uint64(sub) * nkc
                for i in range(nkc):
                    hsum[i] -= vs[o_sub + i]
        o_out = np.uint64(x * nk + nr)
        for i in range(nkc):
            out[o_out + i] = hsum[i] * 0.5
    _finish_band_costs(out, width, dmin, ndisp, radius)


@nb.njit(cache=True, inline="always")
def _integer_columns(width, dmin, ndisp, radius):
    """Return ``(lo, hi)``: the columns ``lo <= x < hi`` whose costs are integers or inf.

    No truncated window at any disparity, on either side (``band_lane_costs``).
    """
    return radius + max(0, dmin + ndisp - 1), width - radius + min(0, dmin)


@nb.njit(cache=True, inline="always")
def _cost_column(
    left_t, right_t, x, width, dmin, ndisp, radius, spread, vs, incremental, hsum, out, o_col
):
    """Column ``x`` of ``band_lane_costs`` into ``out[o_col:o_col + nk]``.

    The values of ``band_lane_costs``, one column at a time for ``band_forward``'s fused
    pass. Columns are made in order, ``x = 0`` first: ``hsum`` carries the horizontal
    window sums from one column to the next (and ``vs`` the vertical sums,
    ``_column_sums``). The columns of ``_integer_columns`` have no inf cell and no
    truncated window: they skip the per-disparity checks.
    """
    nr = BAND_ROWS
    win = 2 * radius + 1
    width_p = width + 2 * radius
    nkc = np.uint64(ndisp * nr)
    nk = (ndisp + 2) * nr
    inf = np.inf
    o_out = o_col + np.uint64(nr)
    if x == 0:
        for i in range(nkc):
            hsum[i] = 0
        for c in range(min(radius, width - 1) + 1):
            o_c = _column_sums(
                left_t, right_t, c, width, width_p, dmin, ndisp, radius, spread, vs, incremental
            )
            for i in range(nkc):
                hsum[i] += vs[o_c + i]
        for i in range(nkc):
            out[o_out + i] = hsum[i]
    else:
        add = x + radius
        sub = x - radius - 1
        o_sub = np.uint64(max(sub, 0) * nkc)
        if _moved_column(
            left_t, right_t, vs, hsum, out, add, sub, width, width_p, dmin, ndisp, radius,
            incremental, o_sub, o_out,
        ):  # fmt: skip
            pass
        elif add < width and sub >= 0:  # the bulk of the row: one pass
            o_add = _column_sums(
                left_t, right_t, add, width, width_p, dmin, ndisp, radius, spread, vs, incremental
            )
            for i in range(nkc):
                h = np.int32(hsum[i] + (vs[o_add + i] - vs[o_sub + i]))
                hsum[i] = h
                out[o_out + i] = h
        else:
            if add < width:
                o_add = _column_sums(
                    left_t, right_t, add, width, width_p, dmin, ndisp, radius, spread, vs,
                    incremental,
                )  # fmt: skip
                for i in range(nkc):
                    hsum[i] += vs[o_add + i]
            elif sub >= 0:
                for i in range(nkc):
                    hsum[i] -= vs[o_sub + i]
            for i in range(nkc):
                out[o_out + i] = hsum[i]
    for r in range(nr):
        out[o_col + r] = inf
        out[o_col + nk - nr + r] = inf
    x_lo, x_hi = _integer_columns(width, dmin, ndisp, radius)
    if x_lo <= x < x_hi:
        return
    for k in range(ndisp):
        d = dmin + k
        x0 = max(0, d)
        x1 = min(width, width + d)  # exclusive; 0 <= x - d < width
        o = o_col + np.uint64((k + 1) * nr)
        if x < x0 or x >= x1:
            for r in range(nr):
                out[o + r] = inf
            continue
        lo_end = min(x0 + radius, x1)
        hi_start = max(x1 - radius, lo_end)
        if x < lo_end or x >= hi_start:
            used = min(x + radius, x1 - 1) - max(x - radius, x0) + 1
            if used != win:
                for r in range(nr):
                    out[o + r] = out[o + r] * win / used


@nb.njit(cache=True, inline="always")
def _window_variance(sm, sq, n, norm):
    """Return a window's variance from its integer sum ``sm`` and sum of squares ``sq``.

    ``n`` pixels, ``norm`` the float64 ``(n * steps)**2``: the int64 numerator of
    ``_kernels.window_variance_row``, bit for bit (``band_lane_variance``'s float64 one
    equals it wherever it is taken; the search makes the right view's from the SSD's sums).
    """
    return float(n * sq - sm * sm) / norm


@nb.njit(cache=True)
def band_lane_variance(sig_t, width, radius, steps, incremental, colsum, colsq, hsum, hsq, out):
    """Window variance of every pixel of the band's rows, in one view's band layout.

    ``sig_t`` is ``left_t`` or ``right_t`` of ``band_lane_signals`` (the rows as for
    ``band_lane_costs``); ``out[u * R + r]`` is the variance of the window at storage
    column ``u`` of lane ``r``: left pixel ``x = u``, right pixel ``x = width - 1 - u``
    (the right view is stored right to left). The values of ``_kernels.window_variance_row``
    bit for bit: exact integer sums, then the same one float64 expression. ``colsum`` and
    ``colsq`` (float64, ``wp * R``) keep the vertical window sums of the signal and of its
    square; ``incremental`` moves them down a row (row 0 of ``sig_t`` leaving, row 1
    entering), else they are summed afresh from its ``2 radius + 1`` window rows.
    ``hsum``/``hsq`` (float64, ``width * R``) are scratch for the window sums.

    The sums are integers held as float64, exact while ``n * S**2 < 2**53`` (``n`` the
    window's pixels, ``S`` the largest signal magnitude): for the matching signal (``S =
    4080``) at every window up to ``params.MAX_WINDOW``. The variance's numerator
    ``n * sq - sm**2`` is exact in float64 while ``n * sq < 2**53`` (``sm**2 <= n * sq``),
    which holds below some 150 pixels a side; where a window passes it (a flag set in the
    same loop) the numerators are made again from the same sums in int64, as
    ``window_variance_row`` makes them.
    (int64 sums had cost three multiplications per square and a scalar conversion per
    pixel on AVX2, which has no 64-bit vector multiply or conversion to float64.)
    """
    nr = BAND_ROWS
    win = 2 * radius + 1
    n = win * win
    width_p = width + 2 * radius
    m = np.uint64(width_p * nr)
    if incremental:
        for i in range(m):  # row 0 leaves, row 1 enters
            ve = float(sig_t[m + i])
            vl = float(sig_t[i])
            colsum[i] += ve - vl
            colsq[i] += ve * ve - vl * vl
    else:
        for i in range(m):
            v = float(sig_t[i])
            colsum[i] = v
            colsq[i] = v * v
        for t in range(1, win):
            o = np.uint64(t) * m
            for i in range(m):
                v = float(sig_t[o + i])
                colsum[i] += v
                colsq[i] += v * v
    fn = float(n)
    norm = fn * fn * float(steps) * float(steps)
    # the window sums of storage column 0, then a running sum along the columns (one flat
    # loop: each lane's sum at i from the one at i - R); ``over``: some ``n * sq`` is not
    # exact (a flag, not a largest value: a float max stops the loop's vector form)
    unr = np.uint64(nr)
    over = False
    for r in range(unr):
        sm = 0.0
        sq = 0.0
        for c in range(win):
            sm += colsum[c * nr + r]
            sq += colsq[c * nr + r]
        hsum[r] = sm
        hsq[r] = sq
        top = fn * sq
        over |= top >= 2.0**53
        out[r] = (top - sm * sm) / norm
    o_add = np.uint64((win - 1) * nr)
    for i in range(unr, np.uint64(width * nr)):
        sm = hsum[i - unr] + colsum[o_add + i] - colsum[i - unr]
        sq = hsq[i - unr] + colsq[o_add + i] - colsq[i - unr]
        hsum[i] = sm
        hsq[i] = sq
        top = fn * sq
        over |= top >= 2.0**53
        out[i] = (top - sm * sm) / norm
    if over:
        for i in range(np.uint64(width * nr)):
            out[i] = _window_variance(np.int64(hsum[i]), np.int64(hsq[i]), n, norm)


# --------------------------------------------------------------------------- DP
#
# The costs are flat: cell ``k`` of band row ``r`` in column ``x`` is
# ``cost[x * nk + (k + 1) * R + r]``; the column functions get the offsets of their columns
# (unsigned, see above) and loop over ``p = (k + 1) * R + r``, so that a step to ``k + 1``
# is ``p + R``. The forward pass keeps the DP values of only three columns (``x``, ``x - 1``
# and ``x - 2``: all a step reads), and records for every cell, in ``steps`` (one 32-bit
# word per block of ``R`` cells, see ``STEP_LANE``), which steps reach its value. The
# backtrack takes the first of them in the order of preference of
# ``_kernels.scanline_dp``'s backtrack (c, d, e, a, then b: ``_cell_step``) instead of
# recomputing the five candidates from the costs and the table: the same comparisons of
# the same values, made once in vector loops.

#: Bytes of a block's step word (see ``STEP_LANE``): the one whose bit ``r`` says that step
#: c (d, e, a) reaches row ``r``'s cell. The vector code, its twins and ``_cell_step`` all
#: take the layout from these.
STEP_BYTE_C = 0
STEP_BYTE_D = 1
STEP_BYTE_E = 2
STEP_BYTE_A = 3

#: The forward pass records the steps of a block of ``R`` cells (one disparity, the band's
#: rows) in one 32-bit word: byte ``STEP_BYTE_C`` has bit ``r`` set where step c reaches
#: row ``r``'s value, the other bytes the same for d, e and a (b always reaches it: the
#: value is at most the cell above's plus ``occ2``). The vector code makes each byte from
#: one compare's lane mask (``vmovmskpd`` / ``kmovb``) instead of narrowing eight 64-bit
#: masks to bytes, which on AVX2 took a third of the five-step cell's instructions.
#: ``STEP_LANE << r`` are row ``r``'s four bits.
STEP_LANE = 0x01010101


@nb.njit(cache=True, inline="always")
def _cell_step(steps, o, r):
    """Return the step into lane ``r``'s cell of block word ``steps[o]``: c, d, e, a, else b."""
    w = (steps[o] >> r) & STEP_LANE
    if w & (1 << 8 * STEP_BYTE_C):
        return STEP_C
    if w & (1 << 8 * STEP_BYTE_D):
        return STEP_D
    if w & (1 << 8 * STEP_BYTE_E):
        return STEP_E
    if w & (1 << 8 * STEP_BYTE_A):
        return STEP_A
    return STEP_B


def _set_cell_steps(steps, o, r, c, d, e, a):
    """Record which of the steps c, d, e, a reach lane ``r``'s cell of block word ``steps[o]``."""
    word = 0
    for reached, byte in ((c, STEP_BYTE_C), (d, STEP_BYTE_D), (e, STEP_BYTE_E), (a, STEP_BYTE_A)):
        word |= int(reached) << (8 * byte + r)
    steps[o] = (steps[o] & np.uint32(0xFFFFFFFF ^ (STEP_LANE << r))) | np.uint32(word)


@nb.njit(cache=True, inline="always")
def _anchor_step(c, d, e):
    """Return ``(value, step)`` of an anchor cell from its match steps c, d and e.

    The value is ``min(min(c, d), e)``; the step the first of c, d, e that reaches it
    (``STEP_NONE`` if none does). Of ``_cells5_chain``'s pinned lanes and of
    ``band_forward``'s anchors in scalar code.
    """
    best = min(min(c, d), e)
    step = STEP_E if e == best else STEP_NONE
    step = STEP_D if d == best else step
    return best, STEP_C if c == best else step


def _cells5_chain(
    cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi, occ2, slant2, e_off=None,
    pin_k=None, pin_total=None, pin_steps=None, o_pin=0,
):  # fmt: skip
    """Five-step cells ``k_lo..k_hi`` of one column, in one descending loop.

    ``cur``, ``prev`` and ``prev2``: the values of columns ``x``, ``x - 1`` and ``x - 2``.
    The steps from earlier columns (c, d, e, a: ``_earlier_steps5``, the same expressions
    in the same order), then the b step from the cell above: ``min`` with its value plus
    ``occ2`` (the value of ``scanline_dp``'s branch). Which steps reach the cell's value
    goes to the word of its block, ``steps[o_steps + p // R]`` (see ``band_forward``).
    Compiled code runs ``_cells5_vector`` (the same operations, a block of ``R`` cells at a
    time).

    The pins of ``band_forward``, per lane ``r`` (None: none in this column):

    * ``e_off[r]`` (float64, ``R``): 0, or inf for a lane pinned at ``x - 1``, added to
      ``prev2`` in the e step, which then cannot jump over the anchor (``v + 0`` is ``v``:
      the other lanes' values are unchanged, bit for bit);
    * ``pin_k[r]`` (float64, ``R``): ``k`` of the lane's anchor in this column, or -1.
      A pinned lane's earlier steps are replaced by 0 at the anchor and inf elsewhere, so
      the b chain leaves the anchor at 0, the cells below it at ``occ2``, ``2 occ2``, ...
      (the sums in that order) and inf above it: the column restarts at the anchor.
      Its step words are those of these values; the backtrack never reads them
      (``band_backtrack_row`` ends a segment on reaching an anchor's column). With
      ``pin_k``, ``pin_total[o_pin + r]`` (float64) gets the anchor's value by a match
      step, ``min(min(c, d), e)`` of its cell (the total of the segment it ends), and
      ``pin_steps[o_pin + r]`` (int64) the first of c, d, e that reaches it (``STEP_C``,
      ``STEP_D``, ``STEP_E``; ``STEP_NONE`` if none does); the unpinned lanes' entries
      are not written. Every pinned lane's ``k`` must lie in ``k_lo..k_hi``.
    """
    nr = np.uint64(BAND_ROWS)
    top = np.uint64((k_hi + 2) * BAND_ROWS - 1)
    for i in range(np.uint64((k_hi - k_lo + 1) * BAND_ROWS)):
        p = top - i
        h2 = 2.0 * cost[o_here + p]
        c = prev[p] + h2
        u = h2 + cost[o_left + p] + slant2
        d = prev[p + nr] + cost[o_here + p + nr] + u
        if e_off is None:
            e = prev2[p - nr] + cost[o_left + p - nr] + u
        else:
            e = prev2[p - nr] + e_off[p % nr] + cost[o_left + p - nr] + u
        a = prev[p - nr] + occ2
        cell = min(min(c, d), min(e, a))
        if pin_k is not None and pin_k[p % nr] >= 0:
            at = pin_k[p % nr] == np.float64(p // nr - 1)
            if at:
                i_pin = int(o_pin) + int(p % nr)  # ints: np.int64 + np.uint64 is float
                pin_total[i_pin], pin_steps[i_pin] = _anchor_step(c, d, e)
            cell = 0.0 if at else np.inf
        v = min(cell, cur[p + nr] + occ2)
        cur[p] = v
        _set_cell_steps(steps, o_steps + p // nr, int(p % nr), c == v, d == v, e == v, a == v)


def _cells3_chain(cur, prev, cost, o_here, steps, o_steps, k_lo, k_hi, occ2):
    """Three-step cells: steps c and a (``_earlier_steps3``), then b (see ``_cells5_chain``)."""
    nr = np.uint64(BAND_ROWS)
    top = np.uint64((k_hi + 2) * BAND_ROWS - 1)
    for i in range(np.uint64((k_hi - k_lo + 1) * BAND_ROWS)):
        p = top - i
        c = prev[p] + 2.0 * cost[o_here + p]
        a = prev[p - nr] + occ2
        v = min(min(c, a), cur[p + nr] + occ2)
        cur[p] = v
        _set_cell_steps(steps, o_steps + p // nr, int(p % nr), c == v, False, False, a == v)


# The b step makes each column one chain down the disparities (a cell's value is the
# least of its earlier steps and the value of the cell above plus ``occ2``). numba's
# vectorized form of the flat loop over ``(k, r)`` kept that chain in memory: each block
# of 8 cells stored, loaded back by the next block, and reversed twice (the loop runs
# down, and the vector lanes up), about 18 cycles of latency per block. Here the chain and
# the neighbouring blocks (``prev`` at ``k + 1`` and ``k - 1``, the costs at ``k + 1``)
# stay in registers from one block to the next: the block's new loads are ``prev`` and
# ``prev2`` below it, its cost here and the left column's cost below it.


def compile_target():
    """Return what numba compiles for: ``(cpu name, features)``, features as ``"+avx2"`` etc.

    The host's, unless ``NUMBA_CPU_NAME`` / ``NUMBA_CPU_FEATURES`` set them.
    """
    name = config.CPU_NAME or llvm.get_host_cpu_name()
    features = config.CPU_FEATURES or llvm.get_host_cpu_features().flatten()
    return name, features.split(",")


def _wide_vectors():
    """Whether numba compiles for AVX-512 (32 vector registers, ``R`` lanes in one)."""
    return "+avx512f" in compile_target()[1]


#: Whether the cells' vector code carries the blocks it has loaded (the left and upper
#: neighbours of the next block) in registers from one block to the next. With AVX-512's
#: 32 registers it does. With AVX2's 16, where each value of ``R`` lanes takes two, the
#: carried values were spilled to the stack and loaded back every block: loading them
#: again from the arrays (in L1) made dsi5 4-7 % faster (A/B in one process, tsukuba,
#: venus, teddy). Tests exercise the branch of the host they run on.
_CARRY = _wide_vectors()

#: Whether ``band_forward`` makes the anchors inside the five-step cells' vector code (the
#: pinned forms of ``_cells5_chain``: the column's restart at the anchor and the anchor's
#: match steps, a select or two a block; AVX-512), or, after the column's cells, makes each
#: pinned row's anchor from its neighbours and stores the row's restart (scalar code, a
#: store per cell of that row; AVX2). The e-step guard (``e_off``, an addition a block) is
#: in the vector code on both (on AVX2 in every column after the first, without a branch).
#: With AVX-512's 32 registers the vector form was 0.93-0.99 of dc's time (docs/SPEED.md,
#: stop 30). With AVX2's 16, where each value of ``R`` lanes takes two, the pinned forms
#: spilled to the stack every block: the scalar form is 0.91-0.94 of dc's time on the
#: Middlebury scenes there, and about as fast where nearly every pixel is a pair
#: (docs/SPEED.md, stop 44). Tests exercise the branch of the host they run on (and the
#: plain-Python one both); the pinned forms are tested against their twin on every host.
_PINS_IN_LOOP = _wide_vectors()


def _cells_codegen(five, guarded=False, pinning=False):
    def codegen(context, builder, sig, args):
        if five:
            _, _, _, _, o_here, o_left, _, o_steps, k_lo, k_hi, occ2, slant2 = args[:12]
        else:
            _, _, _, o_here, _, o_steps, k_lo, k_hi, occ2 = args

        def data(*indices):
            return (_array_data(context, builder, sig, args, i) for i in indices)

        if five:
            cur, prev, prev2, cost, steps_data = data(0, 1, 2, 3, 6)
        else:
            cur, prev, cost, steps_data = data(0, 1, 2, 4)
        steps_data = builder.gep(steps_data, [o_steps])
        width = ir.Constant(_I64, BAND_ROWS)
        word_type = ir.IntType(32)
        occ2_vec = _broadcast(builder, occ2, _VEC_F64)
        two = _vector_of(2.0, _VEC_F64)

        def lanes(mask, byte):
            # the lanes' compare results as the bits of one byte of the block's word
            bits = builder.zext(builder.bitcast(mask, ir.IntType(BAND_ROWS)), word_type)
            return builder.shl(bits, ir.Constant(word_type, 8 * byte))

        top = builder.mul(builder.add(k_hi, ir.Constant(_I64, 1)), width)  # block k_hi + 1
        above = builder.add(top, width)
        count = builder.add(builder.sub(k_hi, k_lo), ir.Constant(_I64, 1))
        # the values carried from the block above (each alloca becomes a register; without
        # _CARRY, a load at the start of each block)
        chain = cgutils.alloca_once_value(builder, _load_vector(builder, cur, above))
        prev_here = cgutils.alloca_once_value(builder, _load_vector(builder, prev, top))
        zero = ir.Constant(_I64, 0)
        if guarded:
            e_off_vec = _load_vector(builder, _array_data(context, builder, sig, args, 12), zero)
        if pinning:
            pin_k_vec = _load_vector(builder, _array_data(context, builder, sig, args, 13), zero)
            pinned_lanes = builder.fcmp_ordered(">=", pin_k_vec, _vector_of(0.0, _VEC_F64))
            inf_vec = _vector_of(float("inf"), _VEC_F64)
            zero_vec = _vector_of(0.0, _VEC_F64)
            # the match steps c, d, e of each pinned lane's anchor cell, kept as the loop
            # passes it (a select each), for the anchor's value and step after the loop
            at_anchor = [cgutils.alloca_once_value(builder, inf_vec) for _ in range(3)]
        if five:
            slant2_vec = _broadcast(builder, slant2, _VEC_F64)
            prev_up = cgutils.alloca_once_value(builder, _load_vector(builder, prev, above))
            cost_up = cgutils.alloca_once_value(
                builder, _load_vector(builder, cost, builder.add(o_here, above))
            )
            left_here = cgutils.alloca_once_value(
                builder, _load_vector(builder, cost, builder.add(o_left, top))
            )
        with cgutils.for_range(builder, count) as loop:
            p = builder.sub(top, builder.mul(loop.index, width))
            below = builder.sub(p, width)
            if not _CARRY:
                up = builder.add(p, width)
                builder.store(_load_vector(builder, prev, p), prev_here)
                if five:
                    builder.store(_load_vector(builder, prev, up), prev_up)
                    builder.store(_load_vector(builder, cost, builder.add(o_here, up)), cost_up)
                    builder.store(_load_vector(builder, cost, builder.add(o_left, p)), left_here)
            prev_below = _load_vector(builder, prev, below)
            here = _load_vector(builder, cost, builder.add(o_here, p))
            h2 = builder.fmul(two, here)
            c = builder.fadd(builder.load(prev_here), h2)
            a = builder.fadd(prev_below, occ2_vec)
            if five:
                left_below = _load_vector(builder, cost, builder.add(o_left, below))
                u = builder.fadd(builder.fadd(h2, builder.load(left_here)), slant2_vec)
                d = builder.fadd(builder.fadd(builder.load(prev_up), builder.load(cost_up)), u)
                e2 = _load_vector(builder, prev2, below)
                if guarded:
                    e2 = builder.fadd(e2, e_off_vec)
                e = builder.fadd(builder.fadd(e2, left_below), u)
                cell = _vector_min(builder, _vector_min(builder, c, d), _vector_min(builder, e, a))
                if pinning:
                    k_here = builder.sub(builder.udiv(p, width), ir.Constant(_I64, 1))
                    k_vec = _broadcast(builder, builder.sitofp(k_here, ir.DoubleType()), _VEC_F64)
                    at = builder.fcmp_ordered("==", pin_k_vec, k_vec)
                    for slot, step_value in zip(at_anchor, (c, d, e), strict=True):
                        builder.store(builder.select(at, step_value, builder.load(slot)), slot)
                    pin_value = builder.select(at, zero_vec, inf_vec)
                    cell = builder.select(pinned_lanes, pin_value, cell)
            else:
                cell = _vector_min(builder, c, a)
            v = _vector_min(builder, cell, builder.fadd(builder.load(chain), occ2_vec))
            _store_vector(builder, v, cur, p)
            steps = builder.or_(
                lanes(builder.fcmp_ordered("==", c, v), STEP_BYTE_C),
                lanes(builder.fcmp_ordered("==", a, v), STEP_BYTE_A),
            )
            if five:
                steps = builder.or_(steps, lanes(builder.fcmp_ordered("==", d, v), STEP_BYTE_D))
                steps = builder.or_(steps, lanes(builder.fcmp_ordered("==", e, v), STEP_BYTE_E))
            block = builder.udiv(p, width)
            builder.store(steps, builder.gep(steps_data, [block]), align=4)
            builder.store(v, chain)
            if five:
                builder.store(builder.load(prev_here), prev_up)
                builder.store(here, cost_up)
                builder.store(left_below, left_here)
            builder.store(prev_below, prev_here)
        if pinning:
            match_steps = [builder.load(slot) for slot in at_anchor]
            _store_anchors(context, builder, sig, args, match_steps, pinned_lanes)
        return context.get_dummy_value()

    return codegen


def _store_anchors(context, builder, sig, args, match_steps, pinned_lanes):
    """Store the pinned lanes' anchor values and steps (masked stores).

    ``_cells5_chain``'s ``pin_total`` and ``pin_steps``, from the match steps
    ``(c, d, e)`` at the anchors.
    """
    c, d, e = match_steps
    best = _vector_min(builder, _vector_min(builder, c, d), e)
    step = _vector_of(STEP_NONE, _VEC_I64)
    for value, code in ((e, STEP_E), (d, STEP_D), (c, STEP_C)):  # the first that reaches it
        step = builder.select(builder.fcmp_ordered("==", value, best), _vector_of(code, _VEC_I64),
                              step)  # fmt: skip
    o_pin = args[16]
    for value, index, kind in ((best, 14, "f64"), (step, 15, "i64")):
        data = _array_data(context, builder, sig, args, index)
        masked_store = cgutils.get_or_insert_function(
            builder.module,
            ir.FunctionType(
                ir.VoidType(),
                [value.type, value.type.as_pointer(), ir.IntType(32), pinned_lanes.type],
            ),
            f"llvm.masked.store.v{BAND_ROWS}{kind}.p0",
        )
        pointer = builder.bitcast(builder.gep(data, [o_pin]), value.type.as_pointer())
        builder.call(masked_store, [value, pointer, ir.Constant(ir.IntType(32), 8), pinned_lanes])


def _cells_arguments_ok(arrays, offsets, floats):
    return (
        all(_contiguous(a, types.float64) for a in arrays[:-1])
        and _contiguous(arrays[-1], types.uint32)
        and _words(*offsets)
        and all(f == types.float64 for f in floats)
    )


def _absent(arg_type):
    """Whether an optional argument of an intrinsic or overload was left out (None)."""
    return isinstance(arg_type, (types.NoneType, types.Omitted))


@intrinsic
def _cells5_vector(typingctx, cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi,
                   occ2, slant2, e_off, pin_k, pin_total, pin_steps, o_pin):  # fmt: skip
    guarded, pinning = not _absent(e_off), not _absent(pin_k)
    if not (
        _cells_arguments_ok(
            (cur, prev, prev2, cost, steps), (o_here, o_left, o_steps, k_lo, k_hi), (occ2, slant2)
        )
        and (not guarded or _contiguous(e_off, types.float64))
        and (
            not pinning
            or _contiguous(pin_k, types.float64)
            and _contiguous(pin_total, types.float64)
            and _contiguous(pin_steps, types.int64)
            and _words(o_pin)
        )
    ):
        return None
    signature = types.void(
        cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi, occ2, slant2, e_off,
        pin_k, pin_total, pin_steps, o_pin,
    )  # fmt: skip
    return signature, _cells_codegen(True, guarded, pinning)


@intrinsic
def _cells3_vector(typingctx, cur, prev, cost, o_here, steps, o_steps, k_lo, k_hi, occ2):
    if not _cells_arguments_ok((cur, prev, cost, steps), (o_here, o_steps, k_lo, k_hi), (occ2,)):
        return None
    signature = types.void(cur, prev, cost, o_here, steps, o_steps, k_lo, k_hi, occ2)
    return signature, _cells_codegen(False)


# inlined in numba's IR (a small function: one intrinsic), not left to LLVM's inliner,
# which at stop 43 kept the larger pinned forms of that time out of band_forward (a call a
# column)
@overload(_cells5_chain, inline="always")
def _cells5_compiled(cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi, occ2,
                     slant2, e_off=None, pin_k=None, pin_total=None, pin_steps=None,
                     o_pin=0):  # fmt: skip
    def run(cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi, occ2, slant2,
            e_off=None, pin_k=None, pin_total=None, pin_steps=None, o_pin=0):  # fmt: skip
        _cells5_vector(
            cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi, occ2, slant2,
            e_off, pin_k, pin_total, pin_steps, np.int64(o_pin),
        )  # fmt: skip

    return run


@overload(_cells3_chain)
def _cells3_compiled(cur, prev, cost, o_here, steps, o_steps, k_lo, k_hi, occ2):
    def run(cur, prev, cost, o_here, steps, o_steps, k_lo, k_hi, occ2):
        _cells3_vector(cur, prev, cost, o_here, steps, o_steps, k_lo, k_hi, occ2)

    return run


@nb.njit(cache=True)
def band_forward(
    cost,
    width,
    dmin,
    ndisp,
    occ2,
    five,
    slant2,
    anchored,
    pins,
    pinned,
    anchor_total,
    anchor_steps,
    ring,
    steps,
    ends,
    make_costs,
):
    """Forward pass of the whole-scanline DP (eq. 5) of the ``BAND_ROWS`` rows of a band.

    ``make_costs`` None: ``cost`` comes from ``band_lane_costs``. Otherwise it is
    ``(left_t, right_t, radius, spread, vs, incremental, hsum)`` as ``band_lane_costs``
    takes them (``incremental``: ``SUMS_READY`` after ``band_block_match`` made the costs),
    ``cost`` is scratch of two columns (``2 * nk``), and the pass makes each
    column's costs itself, just before the column's cells (``_cost_column``): the same
    values, without the band's cost array, which on wide images and disparity ranges
    leaves the caches. (None is a type of its own to the compiler: the two uses are two
    compiled functions, and the one with the array has no trace of the other.)

    Node ``(x, dmin + k)`` of band row ``r`` gets the value of ``scanline_dp``'s table
    (with ``x_lo = j_lo = 0``, ``x_hi = j_hi = width - 1``) and the steps that reach it to
    bits ``r``, ``8 + r``, ``16 + r`` and ``24 + r`` (c, d, e, a) of the word
    ``steps[x * (ndisp + 2) + k + 1]`` (uint32, ``width * (ndisp + 2)``; ``STEP_LANE``,
    ``_cell_step``). ``ring`` (float64, ``(3, nk)``) holds the values of the last three
    columns (the cells of a column are
    made by ``_cells5_chain`` or ``_cells3_chain``, vector code). ``ends`` (float64,
    ``2 * ndisp * R``) gets the values of the free end's nodes: at ``k * R + r`` the node
    with ``j = width - 1`` and ``x < width - 1`` of disparity index ``k`` (inf where there
    is none), at ``(ndisp + k) * R + r`` the node of the last column.

    With ``anchored``, ``pins[x * R + r]`` (int64) is the right pixel band row ``r`` is
    pinned to at ``x`` (-1: none; increasing in ``x`` along a row, every pair inside the
    disparity range), ``pinned[x]`` whether any row of the band is pinned at ``x``; the
    match-step value of each anchor cell (the total of the segment it ends) goes to
    ``anchor_total[x * R + r]`` and the step into it (the first of c, d, e that reaches
    its value; ``STEP_NONE`` if none does) to ``anchor_steps[x * R + r]``. The column of
    an anchor then holds only the anchor (0) and the b steps below it (their step bits are
    not read: the backtrack ends a segment on reaching the anchor's column,
    ``band_backtrack_row``);
    the e step over an anchor, from column ``x - 2`` to ``x``, reads inf. Where
    ``_PINS_IN_LOOP`` (AVX-512), the five-step cells' vector code does both
    (``_cells5_chain``'s ``pin_k`` and ``e_off``, in the columns that need them) and makes
    the anchors' values and steps (a select per block of the three match steps, masked
    stores after the column): ``dc`` 0.93-0.99 of its time on tsukuba and venus against
    the scalar form, 0.83 on the 3000 x 2000 x 256 pair (docs/SPEED.md, stop 30).
    Otherwise (AVX2), and for the three-step DP and the first column, the columns run the
    plain cells (or the guard's form), and then each pinned row's anchor is made from its
    neighbours by the same operations and its cells of the column are stored.
    """
    nr = BAND_ROWS
    nk = (ndisp + 2) * nr
    unk = np.uint64(nk)
    inf = np.inf
    free = np.ones(nr, dtype=np.bool_)  # the virtual start: before a row's first anchor
    e_off = np.zeros(nr)
    pin_k = np.full(nr, -1.0)
    # the cells of an anchor's column, from restart[ndisp + 1 + k_a - k]: inf above the
    # anchor (k > k_a), then the anchor (0) and the cells m b steps below it (0 + occ2 +
    # ... + occ2, in that order), so that one loop of fixed length stores a column
    restart = np.empty(2 * ndisp + 2)
    for m in range(ndisp + 1):
        restart[m] = inf
    restart[ndisp + 1] = 0.0
    for m in range(ndisp + 2, 2 * ndisp + 2):
        restart[m] = restart[m - 1] + occ2
    cur = ring[0]
    prev = ring[1]  # column -1, the virtual start
    prev2 = ring[2]  # column -2
    for i in range(unk):
        prev[i] = inf
        prev2[i] = inf
    for k in range(min(ndisp, -dmin + 1)):  # j = -1 - dmin - k >= -1
        for r in range(nr):
            prev[(k + 1) * nr + r] = 0.0
    for i in range(np.uint64(2 * ndisp * nr)):
        ends[i] = inf
    for x in range(width):
        o_steps = np.uint64(x * (ndisp + 2))
        if make_costs is None:
            o_here = np.uint64(x * nk)
            o_left = o_here - unk if x >= 1 else o_here
        else:
            o_here = np.uint64((x % 2) * nk)
            o_left = np.uint64(((x + 1) % 2) * nk) if x >= 1 else o_here
            left_t, right_t, radius, spread, vs, incremental, hsum = make_costs
            _cost_column(
                left_t,
                right_t,
                x,
                width,
                dmin,
                ndisp,
                radius,
                spread,
                vs,
                incremental,
                hsum,
                cost,
                o_here,
            )
        k_lo = max(0, x - (width - 1) - dmin)
        k_hi = min(ndisp - 1, x - dmin)
        pin_here = anchored and pinned[x]
        # the e step's guard: on AVX2 every column after the first takes it (e_off 0 in
        # the rows not pinned at x - 1; e2 + 0.0 is e2), one form of the cells instead of
        # a branch on the pins of x - 1 that the processor could not predict (dc 0.97 of
        # its time, docs/SPEED.md, stop 45)
        guard = anchored and five and x >= 1 and (not _PINS_IN_LOOP or pinned[x - 1])
        if guard:
            # rows pinned at x - 1: no e step from x - 2 over the anchor
            for r in range(nr):
                e_off[r] = inf if pins[(x - 1) * nr + r] >= 0 else 0.0
        if pin_here:
            for r in range(nr):
                j = pins[x * nr + r]
                if _PINS_IN_LOOP:
                    pin_k[r] = np.float64(x - j - dmin) if j >= 0 else -1.0  # the anchor's k
                if j >= 0:
                    free[r] = False
        if k_lo > k_hi:
            for i in range(unk):
                cur[i] = inf
        else:
            for i in range(np.uint64((k_lo + 1) * nr)):
                cur[i] = inf
            for i in range(np.uint64((k_hi + 2) * nr), unk):
                cur[i] = inf
        k_virtual = x - dmin + 1  # j = -1
        if 0 <= k_virtual < ndisp:
            for r in range(nr):
                cur[(k_virtual + 1) * nr + r] = 0.0 if free[r] else inf
        if k_lo <= k_hi:
            slant_ok = five and x >= 1
            in_loop = _PINS_IN_LOOP and slant_ok
            # the pins in the cells' vector code: a compiled form for each set of them,
            # each column the one it needs (e_off, pin_k or both cost a vector operation or
            # three per block; without in_loop, e_off only). Spelled-out calls: the
            # arguments passed as one tuple (*cells) made dc 1.06-1.09x slower on tsukuba
            # and venus (A/B in one process)
            o_pin = np.int64(x * nr)
            if in_loop and guard and pin_here:
                _cells5_chain(
                    cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi, occ2,
                    slant2, e_off, pin_k, anchor_total, anchor_steps, o_pin,
                )  # fmt: skip
            elif in_loop and pin_here:
                _cells5_chain(
                    cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi, occ2,
                    slant2, None, pin_k, anchor_total, anchor_steps, o_pin,
                )  # fmt: skip
            elif slant_ok and guard:
                _cells5_chain(
                    cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi, occ2,
                    slant2, e_off,
                )  # fmt: skip
            elif slant_ok:
                _cells5_chain(
                    cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi, occ2,
                    slant2,
                )  # fmt: skip
            else:
                _cells3_chain(cur, prev, cost, o_here, steps, o_steps, k_lo, k_hi, occ2)
            if pin_here and not in_loop:
                # the pins in scalar code, after the column's cells (every column on AVX2;
                # the three-step cells and the first column): each pinned row's cells of
                # this column are replaced, and its anchor made from the columns before (an
                # e step over an anchor at x - 1 adds e_off's inf, as the vector code does)
                for r in range(nr):
                    j = pins[x * nr + r]
                    if j < 0:
                        continue
                    # the anchor ends a segment: its value by a match step (c, d, e; no a,
                    # no b: those of _cells5_chain's, the same operations in the same
                    # order), and the first of them that reaches it ...
                    k_a = x - j - dmin
                    p = int((k_a + 1) * nr + r)  # an int: np.uint64 + np.int64 is float
                    h2 = 2.0 * cost[o_here + p]
                    c = prev[p] + h2
                    best = c
                    step = STEP_C
                    if slant_ok:
                        u = h2 + cost[o_left + p] + slant2
                        d = prev[p + nr] + cost[o_here + p + nr] + u
                        e2 = prev2[p - nr]
                        if guard:
                            e2 += e_off[r]  # inf: an anchor at x - 1 (0: e2 itself)
                        e = e2 + cost[o_left + p - nr] + u
                        best, step = _anchor_step(c, d, e)
                    anchor_total[x * nr + r] = best
                    anchor_steps[x * nr + r] = step
                    # ... and starts the next one: the column holds only the anchor (0)
                    # and the b steps below it (the values of clearing it and running the
                    # b-chain), which the backtrack of that segment takes without reading
                    # their steps
                    # (one loop whose length is the column's, not two that end at the
                    # anchor: an exit the processor predicts)
                    o_restart = ndisp + 1 + k_a
                    for k in range(k_lo, k_hi + 1):
                        cur[(k + 1) * nr + r] = restart[o_restart - k]
        # the free end's nodes: j == width - 1 before the last column, then the last column
        k_end = x - (width - 1) - dmin
        if x < width - 1 and 0 <= k_end < ndisp:
            for r in range(nr):
                ends[k_end * nr + r] = cur[(k_end + 1) * nr + r]
        if x == width - 1:
            for k in range(ndisp):
                for r in range(nr):
                    ends[(ndisp + k) * nr + r] = cur[(k + 1) * nr + r]
        prev2, prev, cur = prev, cur, prev2


@nb.njit(cache=True)
def band_backtrack_row(
    steps,
    ends,
    width,
    dmin,
    ndisp,
    r,
    anchor_x,
    nanchors,
    pins,
    anchor_total,
    anchor_steps,
    disp_row,
    flag_row,
):
    """Paths of band row ``r`` after ``band_forward``: write disparities, flags; return the total.

    As ``gcp_row``, segment by segment: each segment that ends at an anchor (from the free
    start or the anchor before) is traced from it when its value is finite, and the anchor
    pixel gets ``x - j``, flag 0; the last segment ends free (none when the last anchor is
    the row's last pixel). The total is the sum of the segment totals in order (inf when a
    segment has no path). The anchors are the columns ``anchor_x[:nanchors]``, increasing
    (those with ``pins[x * R + r] >= 0``; none in free mode). ``disp_row``/``flag_row``
    must hold NaN/border.

    One walk down the row from its end, segment after segment: a segment writes only its
    own columns (after its starting anchor, up to its end), so the order in which the
    segments are traced changes nothing, and a walk that reaches the starting anchor's
    column goes on from that anchor, without a call and a loop exit per segment. The
    steps are those of ``steps`` (``ndisp + 2`` words a column, see ``band_forward``),
    and into an anchor ``anchor_steps``; the writes are those of ``apply_path``. A path
    that reaches the starting anchor's column is at the anchor or below it, and from
    there only b steps lead to it (``band_forward`` keeps the other cells of that column
    at inf, and no e step crosses it), which write nothing: the segment ends there.
    """
    nr = BAND_ROWS
    nwords = ndisp + 2
    inf = np.inf
    total = 0.0
    for i in range(nanchors):
        total += anchor_total[anchor_x[i] * nr + r]
    anchored = nanchors > 0  # the segment being walked starts at an anchor
    x_lo = 0
    j_lo = 0
    if anchored:
        x_lo = anchor_x[nanchors - 1]
        j_lo = pins[x_lo * nr + r]
    # the free end: nodes with x == width - 1, then nodes with j == width - 1
    walking = False
    x = k = s = -1
    if not (anchored and x_lo == width - 1):
        value = inf
        for kk in range(ndisp):
            j = width - 1 - dmin - kk
            if j_lo <= j <= width - 1:
                v = ends[(ndisp + kk) * nr + r]
                if v < value:
                    value = v
                    x = width - 1
                    k = kk
        for kk in range(ndisp):
            xx = width - 1 + dmin + kk
            if x_lo <= xx < width - 1:
                v = ends[kk * nr + r]
                if v < value:
                    value = v
                    x = xx
                    k = kk
        total += value
        if value < inf:
            walking = True
            s = _cell_step(steps, x * nwords + k + 1, r)
    i = nanchors  # the segment being walked ends at anchor i (nanchors: the free end)
    while True:
        while walking:
            if anchored and x == x_lo:
                break  # the rest are b steps up the anchor's column, which write nothing
            d = dmin + k
            if s == STEP_C or s == STEP_D:
                disp_row[x] = d
                flag_row[x] = 0
            elif s == STEP_E:
                disp_row[x] = d
                flag_row[x] = 0
                disp_row[x - 1] = d - 0.5
                flag_row[x - 1] = 0
            elif s == STEP_A:
                disp_row[x] = np.nan
                flag_row[x] = FLAG_OCCLUDED
            if s == STEP_C:
                x -= 1
            elif s == STEP_A:
                x -= 1
                k -= 1
            elif s == STEP_B:
                k += 1
            elif s == STEP_D:
                x -= 1
                k += 1
            else:  # STEP_E (and, as in scanline_dp, STEP_NONE)
                x -= 2
                k -= 1
            if not anchored and (x == -1 or x - dmin - k == -1):
                break
            s = _cell_step(steps, x * nwords + k + 1, r)
        # the next segment down ends at anchor i - 1
        i -= 1
        if i < 0:
            break
        x = anchor_x[i]
        j = pins[x * nr + r]
        disp_row[x] = x - j
        flag_row[x] = 0
        walking = anchor_total[x * nr + r] < inf
        k = x - j - dmin
        s = anchor_steps[x * nr + r]
        anchored = i > 0
        x_lo = anchor_x[i - 1] if anchored else 0
    return total


# --------------------------------------------------------------------------- dc features
#
# The feature search of ``dc`` (``_kernels.divide_row`` with its up-front tests: the
# uniqueness test on, no limit on the tries) on the costs of a band, so that ``dc`` runs on
# the band DP with its pairs as pins. Its results are those of ``divide_row``, bit for bit.


@nb.njit(cache=True, inline="always")
def _first_reaching(pre, ndisp, r, best):
    """Return the first block ``b = k + 1`` (``1..ndisp``) where lane ``r``'s ``pre`` is ``best``.

    ``pre`` holds prefix minima along ``k`` (they do not increase) and ``best`` is lane
    ``r``'s least, ``pre[ndisp]`` (the last block is inf): a binary search without branches,
    the answer in ``b .. b + n - 1``.
    """
    b = 1
    n = ndisp
    while n > 1:
        half = n // 2
        b += half * (pre[(b + half - 1) * BAND_ROWS + r] > best)
        n -= half
    return b


@nb.njit(cache=True, inline="always")
def _key_blocks(ndisp, blocks):
    """Fill ``blocks[i]`` with block ``k + 1`` of flat cell ``i``; return the keys' scale.

    The keyed minima take ``cost * scale + (k + 1)`` (``_column_wta``): ``scale`` is
    the least power of two above the ``ndisp + 2`` blocks, so the keys are exact and
    ordered as ``(cost, k)``. The blocks are a load in the key loops, which costs less
    than the index arithmetic.
    """
    unr = np.uint64(BAND_ROWS)
    for i in range(np.uint64(blocks.shape[0])):
        blocks[i] = np.float64(i // unr)
    return _key_scale(ndisp + 2)


@nb.njit(cache=True, inline="always")
def _key_scale(nblocks):
    """Return the least power of two above ``nblocks``: the keys' scale (``_key_blocks``)."""
    return float(1 << _key_shift(nblocks))


# The keyed columns' least key and second key are one reduction per lane along the
# disparities. numba's loop vectorizer cannot express that (a flat loop over ``(k, r)``
# carries it through memory, as the prefix and suffix chains did: two stores per block
# of 8 cells, and a per-row decode after them), so the keyed column is written as LLVM
# vector code (``<R x double>``, R = ``BAND_ROWS``): ``_KEY_CHAINS`` running minima per
# pass, held in registers, and the decode of the 8 lanes at once. Plain Python runs the twin below
# (``NUMBA_DISABLE_JIT``); the tests hold both to the prefix-chain results.


def _keyed_column(cost, o, nblocks, scale, numbers, wta_k, wta_ratio, i0):
    """Block match of a keyed column: its ``R`` lanes' ``wta_k`` and ``wta_ratio`` at ``i0``.

    ``cost[o + j * R + r]``, blocks ``j = 0 .. nblocks - 1`` (the first and the last are the
    inf padding), holds integers below ``2**31`` or inf; the key of block ``j`` is
    ``cost * scale + j`` (``scale`` a power of two above ``nblocks``), exact and ordered as
    ``(cost, j)``. The least key gives the match (block ``b = k + 1``, the first of the
    least costs) and the least key over ``|j - b| >= 2`` the second cost of the uniqueness
    ratio: the values of ``_kernels.block_match``, bit for bit. ``numbers[j]`` is ``j``
    (float64, at least ``nblocks`` values): the vector code loads each block's ``j``
    instead of counting it up in a vector register (an addition per block, on the
    floating-point pipes the key's fused multiply-add and the minimum need).
    Compiled code runs ``_keyed_column_vector`` instead (the same operations, the lanes as
    one vector).
    """
    nr = BAND_ROWS
    unscale = 1.0 / scale
    for r in range(nr):
        least = np.inf
        for j in range(nblocks):
            least = min(least, cost[o + j * nr + r] * scale + numbers[j])
        i = i0 + r
        if not least < np.inf:
            wta_k[i] = -1
            wta_ratio[i] = 0.0
            continue
        best = np.floor(least * unscale)
        b = int(least - best * scale)
        second = np.inf
        for j in range(nblocks):
            if abs(j - b) >= 2:
                second = min(second, cost[o + j * nr + r] * scale + numbers[j])
        second = np.floor(second * unscale)
        wta_k[i] = b - 1
        if best > 0:
            wta_ratio[i] = second / best
        else:
            wta_ratio[i] = np.inf if second > 0 else 1.0


#: Running minima of ``_keyed_column_vector`` (blocks taken this many at a time).
_KEY_CHAINS = 4


@intrinsic
def _keyed_column_vector(typingctx, cost, o, nblocks, scale, numbers, wta_k, wta_ratio, i0):
    if not (
        _contiguous(cost, types.float64)
        and _contiguous(numbers, types.float64)
        and _contiguous(wta_k, types.int64)
        and _contiguous(wta_ratio, types.float64)
        and scale == types.float64
        and _words(o, nblocks, i0)
    ):
        return None
    signature = types.void(cost, o, nblocks, scale, numbers, wta_k, wta_ratio, i0)

    def codegen(context, builder, sig, args):
        _, o_v, nblocks_v, scale_v, _, _, _, i0_v = args
        data = _array_data(context, builder, sig, args, 0)
        number = _array_data(context, builder, sig, args, 4)
        width = ir.Constant(_I64, BAND_ROWS)
        inf = _vector_of(float("inf"), _VEC_F64)
        one = _vector_of(1.0, _VEC_F64)
        zero = _vector_of(0.0, _VEC_F64)
        scale_vec = _broadcast(builder, scale_v, _VEC_F64)
        unscale = builder.fdiv(one, scale_vec)  # exact: a power of two
        # blocks in groups of _KEY_CHAINS, one running minimum per place in the group (the
        # chains are short: the next column's can start before this one's end); the
        # blocks left over (nblocks % _KEY_CHAINS) go first, into the first minimum
        chains = ir.Constant(_I64, _KEY_CHAINS)
        groups = builder.udiv(nblocks_v, chains)
        rest = builder.urem(nblocks_v, chains)
        least = [cgutils.alloca_once_value(builder, inf) for _ in range(_KEY_CHAINS)]

        def block_number(j):
            return _broadcast(builder, builder.load(builder.gep(number, [j])), _VEC_F64)

        def key(j):
            # cost * scale + j: exact (below 2**53), so the fused multiply-add rounds nothing
            values = _load_vector(builder, data, builder.add(o_v, builder.mul(j, width)))
            return _vector_call(builder, _FMA, values, scale_vec, block_number(j))

        def fold(slot, value, keep=None):
            # keep: the lanes that take the value (a masked minimum, no blend)
            old = builder.load(slot)
            new = _vector_min(builder, old, value)
            builder.store(new if keep is None else builder.select(keep, new, old), slot)

        def fold_all(keep):
            # keep(j): the lanes that block j takes part in (None: all)
            with cgutils.for_range(builder, rest) as loop:
                fold(least[0], key(loop.index), keep(loop.index))
            with cgutils.for_range(builder, groups) as loop:
                j0 = builder.add(rest, builder.mul(loop.index, chains))
                for place in range(_KEY_CHAINS):
                    j = builder.add(j0, ir.Constant(_I64, place))
                    fold(least[place], key(j), keep(j))
            result = builder.load(least[0])
            for slot in least[1:]:
                result = _vector_min(builder, result, builder.load(slot))
            return result

        least_key = fold_all(lambda j: None)  # the least key
        valid = builder.fcmp_ordered("<", least_key, inf)
        best = _vector_call(builder, _FLOOR, builder.fmul(least_key, unscale))
        block = builder.fsub(least_key, builder.fmul(best, scale_vec))  # b = k + 1
        block = builder.select(valid, block, one)
        # the second key: the blocks with |j - b| >= 2, compared as float64 (exact small
        # integers; 64-bit integer lanes would take an unsigned compare, which AVX2 lacks)
        for slot in least:
            builder.store(inf, slot)
        two = _vector_of(2.0, _VEC_F64)
        fabs = f"llvm.fabs.v{BAND_ROWS}f64"

        def apart(j):
            distance = _vector_call(builder, fabs, builder.fsub(block_number(j), block))
            return builder.fcmp_ordered(">=", distance, two)

        second_key = fold_all(apart)
        second = _vector_call(builder, _FLOOR, builder.fmul(second_key, unscale))
        ratio = builder.select(
            builder.fcmp_ordered(">", best, zero),
            builder.fdiv(second, best),
            builder.select(builder.fcmp_ordered(">", second, zero), inf, one),
        )
        # k = b - 1 as an integer: b + 2**52 holds b in its low mantissa bits (exact for
        # 0 <= b < 2**52), one addition and one integer subtraction a vector (AVX2 has no
        # vector conversion of float64 to 64-bit integers: fptosi was eight scalar ones)
        magic = _vector_of(float(2**52), _VEC_F64)
        block_bits = builder.bitcast(builder.fadd(block, magic), _VEC_I64)
        match = builder.sub(block_bits, _vector_of((0x433 << 52) + 1, _VEC_I64))
        match = builder.select(valid, match, _vector_of(-1, _VEC_I64))
        ratio = builder.select(valid, ratio, zero)
        _store_vector(builder, match, _array_data(context, builder, sig, args, 5), i0_v)
        _store_vector(builder, ratio, _array_data(context, builder, sig, args, 6), i0_v)
        return context.get_dummy_value()

    return signature, codegen


@overload(_keyed_column)
def _keyed_column_compiled(cost, o, nblocks, scale, numbers, wta_k, wta_ratio, i0):
    return lambda cost, o, nblocks, scale, numbers, wta_k, wta_ratio, i0: _keyed_column_vector(
        cost, o, nblocks, scale, numbers, wta_k, wta_ratio, i0
    )


@nb.njit(cache=True)
def band_block_match(
    cost, width, ndisp, x_int_lo, x_int_hi, pre, suf, wta_k, wta_ratio, make_costs=None,
    wanted=None, done=None, fused=None, diagonals=None,
):  # fmt: skip
    """Whole-band block match of every left pixel of the ``R`` rows of a band.

    ``wta_k[x * R + r]`` is the least-cost index ``k`` of column ``x`` of band row ``r``
    (ties: the smallest; -1 when the whole band is inf) and ``wta_ratio[x * R + r]`` its
    uniqueness ratio (0 where the band is empty): the values of ``_kernels.block_match``,
    bit for bit (only comparisons and the same one division).

    In columns ``x_int_lo <= x < x_int_hi``, whose costs must all be integers below
    ``2**31`` or inf (``band_lane_costs``: all but the columns of the truncated windows),
    the minima are taken over keys ``cost * M + (k + 1)``, ``M`` a power of two above the
    cell count: exact, and ordered as ``(cost, k)``, so the least key carries the first
    index of the least cost (``_keyed_column``, the 8 lanes as one vector).

    Elsewhere, one flat pass over the cells (a vector loop, the lanes independent): the
    prefix minima ``pre`` and the suffix minima ``suf`` along ``k`` (float64 scratch,
    ``(ndisp + 2) * R``; the inf padding cells are the empty prefix and suffix). The least
    cost is the last prefix minimum, its first index a binary search of the prefix minima
    (they do not increase), and the second cost, over ``|k - best| > 1``, the least of the
    prefix minimum two cells below the match and the suffix minimum two cells above.

    ``make_costs`` None: ``cost`` is the band's array (``band_lane_costs``). Otherwise it
    is ``(left_t, right_t, dmin, radius, spread, vs, incremental, hsum)`` as
    ``band_lane_costs`` takes them, ``cost`` is scratch of one column (``nk``), and each
    column's costs are made into it (``_cost_column``) and matched while they are in the
    cache: ``dc`` without the band's cost array, which on wide images and disparity ranges
    leaves the caches (the same values). The band's vertical sums are left in ``vs``, so
    that the DP pass after it makes the costs again from them (``SUMS_READY``). (As in
    ``band_forward``, None and a tuple compile to two functions.)

    ``wanted`` None: every column. Otherwise ``(counts, guard)`` (``band_strong_counts``):
    only the columns within ``guard`` of a column with a strong pixel are matched, the
    only ones the feature tests read (``band_feature_mask``: a candidate's own column and
    its guard columns); the others get -1 and 0, as an empty column (their costs are
    still made).

    ``done`` None: every column. Otherwise (uint8, ``width``) the columns with ``done[x]``
    are left as they are: ``band_lane_costs`` matched them as it made them.

    ``fused`` (with ``make_costs`` only) None: each column is made, then matched.
    Otherwise ``(x_lo, x_hi, shift)``: the columns ``x_lo <= x < x_hi`` that
    ``_moved_costs`` makes are made and matched at once by ``_moved_costs_keyed``, as
    ``band_lane_costs``' ``match`` does for the band's array (the caller checks
    ``_keys_fit``); they are matched whether ``wanted`` or not (the same values: the
    feature tests read only the wanted columns).

    ``diagonals`` (with ``make_costs`` only) None: nothing more. Otherwise ``(least, second,
    best)`` (``_gcp_scratch``) for ``dsi3-gcp`` without the band's cost array: each column
    made is folded into ``least`` and ``second`` (``_gcp_diagonals``; first set to inf
    here) and each matched column's least cost goes to ``best`` (``_gcp_best``; the
    columns left out by ``wanted`` keep what they held), what ``band_row_gcps`` reads.
    """
    nr = BAND_ROWS
    if diagonals is not None:
        for i in range(width * nr):
            diagonals[0][i] = np.inf
            diagonals[1][i] = np.inf
    unr = np.uint64(nr)
    nblocks = ndisp + 2  # cells k = -1 .. ndisp, the two padding ones included
    unk = np.uint64(nblocks * nr)
    top = unk - unr
    inf = np.inf
    scale = _key_scale(nblocks)
    numbers = np.arange(nblocks).astype(np.float64)  # _keyed_column's j
    for x in range(width):
        if done is not None:
            if done[x]:
                continue
        if make_costs is None:
            o = np.uint64(x) * unk
        else:
            o = np.uint64(0)
            left_t, right_t, dmin, radius, spread, vs, incremental, hsum = make_costs
            if fused is not None:
                # as band_lane_costs' match, written out again: one inline helper for both
                # made dc 1.04-1.09x slower in mode 2 and 1.06x in mode 3 (A/B in one
                # process), as a helper shared with _moved_column had before
                x_lo, x_hi, shift = fused
                add = x + radius
                sub = x - radius - 1
                if x_lo <= x < x_hi and _movable(add, sub, width, dmin, ndisp, incremental):
                    # made and matched at once
                    width_p = width + 2 * radius
                    nkc = np.uint64(ndisp * nr)
                    o_left, o_right, o_add = _moved_offsets(add, dmin, radius, width_p, nkc)
                    _moved_costs_keyed(
                        left_t, right_t, vs, hsum, cost, o_left, o_right, o_add,
                        np.uint64(sub) * nkc, unr, nkc, width_p, shift, wta_k, wta_ratio,
                        np.uint64(x) * unr,
                    )  # fmt: skip
                    if diagonals is not None:
                        least, second, best = diagonals
                        _gcp_diagonals(cost, o, x, dmin, ndisp, width, least, second)
                        _gcp_best(cost, o, x, wta_k, best)
                    continue
            _cost_column(
                left_t, right_t, x, width, dmin, ndisp, radius, spread, vs, incremental, hsum,
                cost, o,
            )  # fmt: skip
            if diagonals is not None:
                least, second, best = diagonals
                _gcp_diagonals(cost, o, x, dmin, ndisp, width, least, second)
        if wanted is not None:
            counts, guard = wanted
            if counts[min(x + guard + 1, width)] == counts[max(x - guard, 0)]:
                for i in range(np.uint64(x) * unr, np.uint64(x + 1) * unr):
                    wta_k[i] = -1
                    wta_ratio[i] = 0.0
                continue
        if x_int_lo <= x < x_int_hi:
            _keyed_column(cost, o, nblocks, scale, numbers, wta_k, wta_ratio, np.uint64(x) * unr)
            if diagonals is not None:
                _gcp_best(cost, o, x, wta_k, diagonals[2])
            continue
        for i in range(unr):
            pre[i] = cost[o + i]  # the padding cells: inf
            suf[top + i] = cost[o + top + i]
        # one loop, two independent chains: the prefix minima up from the bottom, the
        # suffix minima down from the top
        for i in range(top):
            p = unr + i
            q = top - np.uint64(1) - i
            pre[p] = min(pre[p - unr], cost[o + p])
            suf[q] = min(suf[q + unr], cost[o + q])
        for r in range(nr):
            i = x * nr + r
            best = pre[(nblocks - 1) * nr + r]
            if not best < inf:
                wta_k[i] = -1
                wta_ratio[i] = 0.0
                continue
            b = _first_reaching(pre, ndisp, r, best)
            wta_k[i] = b - 1
            second = min(pre[max(b - 2, 0) * nr + r], suf[min(b + 2, nblocks - 1) * nr + r])
            if best > 0:
                wta_ratio[i] = second / best
            else:
                wta_ratio[i] = inf if second > 0 else 1.0
        if diagonals is not None:
            _gcp_best(cost, o, x, wta_k, diagonals[2])


@nb.njit(cache=True, inline="always")
def _gcp_arrays(n):
    """``(least, second, best)``, ``n`` float64 each: ``band_block_match``' ``diagonals``."""
    return (_placed(n, np.float64, 30), _placed(n, np.float64, 31), _placed(n, np.float64, 0))


def _gcp_scratch(gcp, n):
    """``band_block_match``' ``diagonals`` for ``match_band_rows``: None without ``gcp``.

    Otherwise ``_gcp_arrays(n)``. Compiled code takes the overload below, which chooses by
    the type of ``gcp``.
    """
    return None if gcp is None else _gcp_arrays(n)


@overload(_gcp_scratch)
def _gcp_scratch_compiled(gcp, n):
    if isinstance(gcp, (types.NoneType, types.Omitted)):
        return lambda gcp, n: None
    return lambda gcp, n: _gcp_arrays(n)


@nb.njit(cache=True, inline="always")
def _gcp_diagonals(cost, o, x, dmin, ndisp, width, least, second):
    """Fold column ``x`` (at ``cost[o:]``) into the two least costs of each right pixel.

    ``least[(width - 1 - j) * R + r]`` and ``second[...]`` (right pixels in reverse order)
    are the least and the second least (counted with repeats: equal to the least where it
    occurs twice) of lane ``r``'s costs of right pixel ``j``, over the left pixels
    ``x2 = j + dmin + k2`` of the row: the diagonal of the band's costs that
    ``_kernels.select_gcps``' left-right check walks. Only the cells with
    ``0 <= j < width`` are folded (the others are inf). In reverse order a column's
    right pixels ``j = x - dmin - k`` follow its cells, so the fold is one flat loop (a
    vector loop; numba leaves the SLP vectorizer off).
    """
    nr = BAND_ROWS
    k_lo = max(0, x - dmin - width + 1)
    k_hi = min(ndisp, x - dmin + 1)
    if k_hi <= k_lo:
        return
    oc = o + np.uint64((k_lo + 1) * nr)
    od = np.uint64((width - 1 - x + dmin + k_lo) * nr)
    for i in range(np.uint64((k_hi - k_lo) * nr)):
        v = cost[oc + i]
        m = least[od + i]
        second[od + i] = min(second[od + i], max(m, v))
        least[od + i] = min(m, v)


@nb.njit(cache=True, inline="always")
def _gcp_best(cost, o, x, wta_k, best):
    """``best[x * R + r]``: lane ``r``'s cost at its match ``wta_k`` (inf: none)."""
    nr = BAND_ROWS
    for r in range(nr):
        k = wta_k[x * nr + r]
        best[x * nr + r] = cost[o + np.uint64((k + 1) * nr + r)] if k >= 0 else np.inf


@nb.njit(cache=True, inline="always")
def _better(values, a, b):
    """Return the better of candidates ``a`` and ``b`` (larger value; ties: smaller index)."""
    if values[b] > values[a] or (values[b] == values[a] and b < a):
        return b
    return a


@nb.njit(cache=True)
def _sparse_build(values, n, sparse):
    """Sparse table of range maxima: ``sparse[l, i]`` the best of ``i .. i + 2**l - 1``."""
    for i in range(n):
        sparse[0, i] = i
    level = 1
    while (1 << level) <= n:
        half = 1 << (level - 1)
        for i in range(n - (1 << level) + 1):
            # a select, not _better's branches: the right half's index is the larger
            a = sparse[level - 1, i]
            b = sparse[level - 1, i + half]
            sparse[level, i] = b if values[b] > values[a] else a
        level += 1


def _floor_log2(n):
    """Return ``floor(log2(n))`` of an integer ``n >= 1``.

    Compiled code runs ``_floor_log2_ctlz``: 63 less the leading zeros of the 64-bit
    value (one ``lzcnt``), where a loop that doubles a power of two until it passes ``n``
    ends on a branch that depends on ``n``, mispredicted from one interval to the next.
    """
    return int(n).bit_length() - 1


@intrinsic
def _floor_log2_ctlz(typingctx, n):
    if not _words(n):
        return None

    def codegen(context, builder, sig, args):
        flag = ir.IntType(1)
        ctlz = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(_I64, [_I64, flag]), "llvm.ctlz.i64"
        )
        zeros = builder.call(ctlz, [args[0], ir.Constant(flag, 1)])  # n >= 1: never 64
        return builder.sub(ir.Constant(_I64, 63), zeros)

    return types.int64(n), codegen


@overload(_floor_log2)
def _floor_log2_compiled(n):
    return lambda n: _floor_log2_ctlz(n)


@nb.njit(cache=True, inline="always")
def _sparse_best(values, sparse, lo, hi):
    """Return the best candidate of ``lo..hi`` (``lo <= hi``) from two table entries."""
    level = _floor_log2(hi - lo + 1)
    return _better(values, sparse[level, lo], sparse[level, hi - (1 << level) + 1])


#: The forms of ``_window_ssd``'s compiled code (its ``form``, a constant where it is
#: called): the sums in 64-bit lanes, a window row in pieces of ``R`` pixels (any window);
#: in 32-bit lanes, a window of at most ``R`` pixels a side whose sums fit them
#: (``_narrow_sums``; on the matching signal of any image, 0..4080, every such window).
SSD_WIDE, SSD_SHORT = 0, 1


def _window_ssd(left_p, right_p, y, x, j, radius, form):
    """Return ``(ssd, sm, sq)`` of the pair ``x <-> j`` of padded row ``y``.

    ``ssd`` (float64) is the window sum of squared signal differences, ``sm`` and ``sq``
    (int64) the right window's sum and sum of squares, from which the search makes the
    right pixel's window variance (``_window_variance``): the right view's variance is
    read only at the candidates' matches, so it is made there, from the loads of the SSD.
    Both windows inside the image (every feature candidate): exact integers, ``ssd`` the
    value of ``_kernels.window_ssd``. Compiled code runs the vector code of ``form``
    (``SSD_WIDE``, ``SSD_SHORT``: the same sums for int32 signals below 2**30 in
    magnitude, where the form's conditions hold), which must be a constant where it is
    called: one form compiled; here ``form`` is not read, the sums are Python's integers.
    """
    win = 2 * radius + 1
    si = 0
    sm = 0
    sq = 0
    for t in range(win):
        for c in range(win):
            right = np.int64(right_p[y + t, j + c])
            di = np.int64(left_p[y + t, x + c]) - right
            si += di * di
            sm += right
            sq += right * right
    return float(si), sm, sq


# The window's rows are short (5 pixels by default), too short for numba's loop
# vectorizer, which leaves a scalar loop of two loads, a subtraction, a multiplication and
# an addition per pixel. The vector code takes each row ``R`` pixels at a time: masked
# loads (nothing past the window is read), the differences as 32-bit integers (exact for
# signals below 2**30 in magnitude; the matching signal is 0..4080), their squares and
# sums as 64-bit ones, one sum at the end: the same integer, so the same float. A square
# of a sign-extended 32-bit value is one ``vpmuldq``; the difference of two 64-bit values
# was a full 64-bit product, which AVX2 lacks (three ``vpmuludq`` and shifts per four
# lanes): the SSD took about 35 ns on AVX2. The right rows' values are summed, and their
# squares, on the way (two additions and a ``vpmuldq`` a row). A window of at most ``R``
# pixels a side (the default 5, up to 7) whose sums fit 32 bits (``_narrow_sums``: on the
# matching signal of any image) takes the short form, ``SSD_SHORT``: no loop over pieces
# of a row, one masked load per view and row, the sums in 32-bit lanes without the sign
# extensions. Timed alone on 5 x 5 windows (AMD EPYC, AVX2): 60 cycles an SSD with the
# pieces' loop, 43 without it in 64-bit lanes, 24 in 32-bit ones; with the search's SSD in
# a loop of its own, tsukuba's search stage took 0.66 ms against 0.92 (docs/SPEED.md,
# stop 45).


def _window_ssd_codegen(short):
    """Return the code of ``_window_ssd`` in form ``SSD_SHORT`` (``short``) or ``SSD_WIDE``.

    ``short``: for windows of at most ``R`` pixels a side whose sums fit 32 bits (the
    caller checks), one load of a window row per view and row, without the loop over
    pieces of ``R`` pixels, the sums in 32-bit lanes. Else in 64-bit lanes.
    """
    lanes_type = _VEC_I32 if short else _VEC_I64
    sum_type = ir.IntType(32 if short else 64)

    def codegen(context, builder, sig, args):
        y_v, x_v, j_v, radius_v = args[2:]
        views = [context.make_array(sig.args[i])(context, builder, args[i]) for i in (0, 1)]
        win = builder.add(builder.mul(radius_v, ir.Constant(_I64, 2)), ir.Constant(_I64, 1))
        width = ir.Constant(_I64, BAND_ROWS)
        lanes = ir.Constant(_VEC_I64, list(range(BAND_ROWS)))
        mask_type = ir.VectorType(ir.IntType(1), BAND_ROWS)
        masked_load = cgutils.get_or_insert_function(
            builder.module,
            ir.FunctionType(_VEC_I32, [_VEC_I32.as_pointer(), ir.IntType(32), mask_type, _VEC_I32]),
            f"llvm.masked.load.v{BAND_ROWS}i32.p0",
        )
        total = cgutils.alloca_once_value(builder, _vector_of(0, lanes_type))
        right_sum = cgutils.alloca_once_value(builder, _vector_of(0, lanes_type))
        right_squares = cgutils.alloca_once_value(builder, _vector_of(0, lanes_type))

        def add_piece(c):
            # the window's columns c .. c + R - 1 (those of the window: the mask)
            mask = builder.icmp_unsigned(
                "<",
                builder.add(_broadcast(builder, c, _VEC_I64), lanes),
                _broadcast(builder, win, _VEC_I64),
            )

            def corner(view, column):
                # the window's first row in a view, from piece c on, and the row length
                length = cgutils.unpack_tuple(builder, view.shape, 2)[1]
                start = builder.add(builder.mul(y_v, length), builder.add(column, c))
                return builder.gep(view.data, [start]), length

            def window_row(first, length, t):
                # the R pixels of row t (those of the window: the mask)
                pointer = builder.gep(first, [builder.mul(t, length)])
                loaded = builder.call(
                    masked_load,
                    [builder.bitcast(pointer, _VEC_I32.as_pointer()),
                     ir.Constant(ir.IntType(32), 4), mask, _vector_of(0, _VEC_I32)],
                )  # fmt: skip
                return loaded

            left_first, right_first = corner(views[0], x_v), corner(views[1], j_v)
            with cgutils.for_range(builder, win) as rows:
                right32 = window_row(*right_first, rows.index)
                d32 = builder.sub(window_row(*left_first, rows.index), right32)
                d = d32 if short else builder.sext(d32, _VEC_I64)
                builder.store(builder.add(builder.load(total), builder.mul(d, d)), total)
                right = right32 if short else builder.sext(right32, _VEC_I64)
                builder.store(builder.add(builder.load(right_sum), right), right_sum)
                squares = builder.mul(right, right)
                builder.store(builder.add(builder.load(right_squares), squares), right_squares)

        # a short window is one piece; else the pieces of R pixels outside, the rows inside
        if short:
            add_piece(ir.Constant(_I64, 0))
        else:
            pieces = builder.udiv(builder.add(win, ir.Constant(_I64, BAND_ROWS - 1)), width)
            with cgutils.for_range(builder, pieces) as piece:
                add_piece(builder.mul(piece.index, width))
        reduce_add = cgutils.get_or_insert_function(
            builder.module,
            ir.FunctionType(sum_type, [lanes_type]),
            f"llvm.vector.reduce.add.v{BAND_ROWS}i{sum_type.width}",
        )
        ssd = builder.sitofp(builder.call(reduce_add, [builder.load(total)]), ir.DoubleType())
        sums = [builder.call(reduce_add, [builder.load(v)]) for v in (right_sum, right_squares)]
        if short:
            sums = [builder.sext(v, _I64) for v in sums]
        return context.make_tuple(builder, sig.return_type, [ssd, *sums])

    return codegen


def _window_ssd_signature(left_p, right_p, y, x, j, radius):
    """Return the signature of ``_window_ssd``'s forms, None for arguments they refuse."""
    if not (
        all(_contiguous(a, types.int32, 2) for a in (left_p, right_p)) and _words(y, x, j, radius)
    ):
        return None
    return types.Tuple((types.float64, types.int64, types.int64))(left_p, right_p, y, x, j, radius)


@intrinsic
def _window_ssd_vector(typingctx, left_p, right_p, y, x, j, radius):
    signature = _window_ssd_signature(left_p, right_p, y, x, j, radius)
    return None if signature is None else (signature, _window_ssd_codegen(False))


@intrinsic
def _window_ssd_short(typingctx, left_p, right_p, y, x, j, radius):
    signature = _window_ssd_signature(left_p, right_p, y, x, j, radius)
    return None if signature is None else (signature, _window_ssd_codegen(True))


@overload(_window_ssd, prefer_literal=True)
def _window_ssd_compiled(left_p, right_p, y, x, j, radius, form):
    if not all(_contiguous(a, types.int32, 2) for a in (left_p, right_p)):
        return _window_ssd  # other signals (the tests' int64 ones): the loop
    if not isinstance(form, types.IntegerLiteral):
        # a choice made as the code runs, in the search's loop, took the SSD from 24 to 44
        # cycles (docs/SPEED.md, stop 45): a constant form only
        return None
    vector = {SSD_WIDE: _window_ssd_vector, SSD_SHORT: _window_ssd_short}[form.literal_value]
    return lambda left_p, right_p, y, x, j, radius, form: vector(left_p, right_p, y, x, j, radius)


@nb.njit(cache=True, inline="always")
def _narrow_sums(span, magnitude, radius):
    """Whether ``_window_ssd``'s sums fit 32-bit lanes (``band_row_features``' ``short_ssd``).

    ``span`` bounds the absolute difference of two signal values, ``magnitude`` a value's
    absolute value (int64, at least 0). The SSD is at most ``win**2 * span**2``, the right
    window's sum of squares ``win**2 * magnitude**2`` (and its sum no more in magnitude):
    both below 2**31, and no partial sum past its total's bound (the terms of the two
    sums of squares are never negative), so the 32-bit lanes hold every sum exactly. On an
    8-bit image's signal (0..4080) windows up to 11 pixels a side fit (the 32-bit form,
    ``SSD_SHORT``, takes windows of at most ``R`` pixels a side).
    """
    win = 2 * radius + 1
    limit = np.int64(46340)  # 46340**2 < 2**31: the products below cannot overflow int64
    if not (0 <= span <= limit and 0 <= magnitude <= limit and win <= limit):
        return False
    top = np.int64(1) << 31
    return win * win * span * span < top and win * win * magnitude * magnitude < top


@nb.njit(cache=True, inline="always")
def _variance_similarity(var_left, var_right, vs_relative):
    """VS (eq. 3), as ``_kernels.variance_similarity``."""
    vs = abs(var_left - var_right)
    if vs_relative:
        total = var_left + var_right
        vs = vs / total if total > 0 else 0.0
    return vs


@nb.njit(cache=True, inline="always")
def _guard_columns(edge_guard):
    """Return how far a candidate's guard columns lie (0: the cell itself, implied tests).

    One rule for ``band_feature_mask``, which reads the guard columns, and for the block
    match's ``wanted`` columns, which must include every column it reads.
    """
    return max(edge_guard, 0)


@nb.njit(cache=True)
def band_strong_counts(var_l, width, var_floor, counts):
    """Count the strong columns of a band: ``counts[x]`` of the columns before ``x``.

    A column is strong where the window variance of some lane reaches the variance floor
    (``var_l[x * R + r] >= var_floor``, as in ``band_feature_mask``; idle lanes count
    too). ``counts`` (int64, ``width + 1``) tells ``band_block_match`` which columns the
    feature tests read.
    """
    nr = BAND_ROWS
    counts[0] = 0
    for x in range(width):
        strong = False
        for r in range(nr):
            strong |= var_l[x * nr + r] >= var_floor
        counts[x + 1] = counts[x] + strong


@nb.njit(cache=True, inline="always")
def _mask_cell(var_l, wta_k, wta_ratio, i, x, i_a, i_b, dmin, radius, width, var_floor, uniq):
    """Return the cheap tests of cell ``i`` (left pixel ``x``; guard cells ``i_a``, ``i_b``)."""
    k = wta_k[i]
    j = x - dmin - k
    k_a = wta_k[i_a]
    k_b = wta_k[i_b]
    return (
        (var_l[i] >= var_floor)
        & (k >= 0)
        & (wta_ratio[i] >= uniq)
        & (j >= radius)
        & (j <= width - 1 - radius)
        & (k_a >= 0)
        & (abs(k_a - k) <= 1)
        & (wta_ratio[i_a] >= uniq)
        & (k_b >= 0)
        & (abs(k_b - k) <= 1)
        & (wta_ratio[i_b] >= uniq)
    )


@nb.njit(cache=True)
def band_feature_mask(var_l, wta_k, wta_ratio, width, dmin, radius, tests, keep):
    """Mark the pixels of a band that pass the cheap up-front tests of ``divide_row``.

    ``keep[x * R + r]`` (uint8) gets 1 where left pixel ``x`` of band row ``r`` passes the
    variance floor, the uniqueness test, the range test (its match ``j`` at least
    ``radius`` inside the image) and the edge guard (``tests``, see
    ``band_row_features``); 0 elsewhere (the ``radius`` columns at each end included).
    The same comparisons on the same values, without branches: the columns whose guard
    columns lie inside the image are one flat vector loop (the guard cells at fixed
    offsets), the few others clamp them as ``divide_row`` does. VS and SER are left to
    the row search (VS needs the right view's variance at the match: a gather, which
    keeps the loop from being vectorized).
    """
    ser_min, vs_max, vs_relative, var_floor, lr_check, uniq, edge_guard, steps = tests
    nr = BAND_ROWS
    for i in range(np.uint64(width * nr)):
        keep[i] = 0
    if width <= 2 * radius:
        return
    guard = _guard_columns(edge_guard)
    x_lo = min(max(radius, guard), width - radius)  # the vector loop's columns
    x_hi = max(min(width - radius, width - guard), x_lo)
    g = np.uint64(guard * nr)
    for i in range(np.uint64(x_lo * nr), np.uint64(x_hi * nr)):
        x = np.int64(i // np.uint64(nr))
        keep[i] = _mask_cell(
            var_l, wta_k, wta_ratio, i, x, i - g, i + g, dmin, radius, width, var_floor, uniq
        )
    for lo, hi in ((radius, x_lo), (x_hi, width - radius)):  # the border columns
        for x in range(lo, hi):
            i_a = max(x - guard, 0) * nr
            i_b = min(x + guard, width - 1) * nr
            for r in range(nr):
                keep[x * nr + r] = _mask_cell(
                    var_l, wta_k, wta_ratio, x * nr + r, x, i_a + r, i_b + r, dmin, radius, width,
                    var_floor, uniq,
                )  # fmt: skip


@nb.njit(cache=True, inline="always")
def _worth_splitting(a, c, b, e, i_lo, i_hi):
    """1 if interval ``(a, c) <-> (b, e)`` has pixels inside and candidates ``i_lo..i_hi``."""
    return int(c - a > 1) & int(e - b > 1) & int(i_lo <= i_hi)


@nb.njit(cache=True)
def _run_lengths(cand_j, m, length, tails):
    """``length[i]``: the longest run strictly increasing in ``cand_j`` from candidate ``i``.

    Returns the longest of all. O(m log m): from the last candidate back, ``tails[L - 1]``
    is the largest ``j`` that starts a run of length ``L`` among the candidates after
    ``i``, strictly decreasing in ``L`` (a run's second element starts a shorter one with
    a larger ``j``), so the runs that ``i`` can start are a binary search away. The same
    lengths as ``max(length[i2] for i2 > i with cand_j[i2] > cand_j[i]) + 1``, which
    became O(m^2) on wide textured rows (thousands of candidates). ``tails``: scratch of
    ``m``.
    """
    longest = 0
    for i in range(m - 1, -1, -1):
        v = cand_j[i]
        lo = 0  # the count of tails above v: a prefix
        hi = longest
        while lo < hi:
            mid = (lo + hi) // 2
            if tails[mid] > v:
                lo = mid + 1
            else:
                hi = mid
        length[i] = lo + 1
        tails[lo] = v  # tails[lo] <= v, or a new length
        if lo == longest:
            longest += 1
    return longest


@nb.njit(cache=True)
def band_row_gcps(
    cost, width, ndisp, r, dmin, radius, wta_k, keep, iwork, pins, pinned, partner_row,
    diagonals, folded,
):  # fmt: skip
    """Intille and Bobick's ground control points of band row ``r``, as ``_kernels.select_gcps``.

    ``wta_k`` is the band's block match (``band_block_match``); ``keep``
    (``band_feature_mask`` with the points' variance floor and uniqueness, no guard) holds
    the window, variance, uniqueness and range tests. A survivor ``x`` with match ``j`` is
    a candidate when it passes the exact left-right check: over the right pixel's band
    every other left pixel costs strictly more. ``folded`` False: the check walks the
    band's cost array ``cost`` (``band_lane_costs``), up to the first left pixel that costs
    no more (``diagonals`` is not read). True, for a band without the array (``cost``
    is not read): ``diagonals`` is ``(least, second, best)``, and the pixel's cost
    ``best[x * R + r]`` must be the least of the right pixel's costs, and no other equal to
    it (``least`` and ``second``, in ``_gcp_diagonals``' order; ``band_block_match``'
    ``diagonals``). On a band's array the walk is the faster: few survivors, most of them
    stopped early. The points are the longest run of
    candidates strictly increasing in ``j`` too, the first in lexicographic order of the
    candidates. Each point ``x <-> j`` goes to ``pins[x * R + r]`` (which must hold -1),
    ``pinned[x]`` and ``partner_row[x]`` (which must hold -1). Returns their number.
    Scratch: ``iwork`` (int64, at least (4, width)). The longest-run part is a copy of
    ``select_gcps``' (``_run_lengths`` too: each kernel file stands alone, numba's cache
    does not see edits made in another file).
    """
    nr = BAND_ROWS
    nk = (ndisp + 2) * nr
    cand_x = iwork[0]
    cand_j = iwork[1]
    length = iwork[2]
    m = 0
    for x in range(radius, width - radius):
        if not keep[x * nr + r]:
            continue
        k = wta_k[x * nr + r]
        j = x - dmin - k
        if not folded:
            best = cost[x * nk + (k + 1) * nr + r]
            back = True
            for k2 in range(ndisp):
                x2 = j + dmin + k2
                if x2 == x or x2 < 0 or x2 >= width:
                    continue
                if cost[x2 * nk + (k2 + 1) * nr + r] <= best:
                    back = False
                    break
            if not back:
                continue
        else:
            least, second, best_cost = diagonals
            best = best_cost[x * nr + r]
            i = (width - 1 - j) * nr + r  # _gcp_diagonals' order
            if not (least[i] == best and second[i] > best):
                continue
        cand_x[m] = x
        cand_j[m] = j
        m += 1
    # longest strictly increasing subsequence in j, lexicographically first in the index:
    # ``length[i]``: the longest one that starts at candidate i
    longest = _run_lengths(cand_j, m, length, iwork[3])
    n = 0
    need = longest
    last_j = -1
    for i in range(m):
        if need == 0:
            break
        if length[i] == need and cand_j[i] > last_j:
            x = cand_x[i]
            pins[x * nr + r] = cand_j[i]
            pinned[x] = True
            partner_row[x] = cand_j[i]
            last_j = cand_j[i]
            n += 1
            need -= 1
    return n


@nb.njit(cache=True, inline="always")
def _candidate_sums(left_p, right_p, y, r, dmin, radius, cand_x, wta_k, m, ssd, sm, sq, form):
    """``_window_ssd`` of candidates ``cand_x[:m]`` of band row ``r`` with their matches.

    To ``ssd[:m]``, ``sm[:m]`` and ``sq[:m]``, in ``form`` (a constant at each call: one
    form compiled in each loop).
    """
    for q in range(m):
        p = cand_x[q]
        j = p - dmin - wta_k[p * BAND_ROWS + r]
        ssd[q], sm[q], sq[q] = _window_ssd(left_p, right_p, y, p, j, radius, form)


@nb.njit(cache=True)
def band_row_features(
    cost,
    width,
    ndisp,
    r,
    dmin,
    radius,
    left_p,
    right_p,
    y,
    var_l,
    wta_k,
    keep,
    tests,
    short_ssd,
    iwork,
    fwork,
    stack,
    pins,
    pinned,
    pairs_row,
):
    """Find the reliable feature pairs of band row ``r`` (image row ``y``), as ``divide_row``.

    ``cost`` and ``wta_k`` are the band's (``band_lane_costs``, ``band_block_match``);
    ``left_p``/``right_p`` the padded signals; ``var_l`` the window variances of the band
    in the left view (``band_lane_variance``); the right view's are made at the matches
    from the sums of the SSD's loads (``_window_ssd``, in the form ``SSD_SHORT`` where
    ``short_ssd``; ``_window_variance``: the same values). ``tests`` is ``(ser_min,
    vs_max, vs_relative, var_floor, lr_check, uniqueness, edge_guard, signal_steps)``
    (``uniqueness > 0``; no limit on the tries). The up-front
    tests of ``divide_row`` pick the candidates: ``keep`` (``band_feature_mask``) holds
    the outcome of the variance floor, uniqueness, range and guard tests, and VS and SER
    are tested here, on the survivors. The search takes the strongest candidate of each
    interval that lies in its ordering range and passes the left-right test, and splits
    the interval at it; a row whose candidates' matches already increase with ``x``
    (with the left-right check off) accepts them all without it, which relies on the
    mask's range test (every match at least ``radius`` inside the image). Pair
    ``x <-> j`` is written to ``pins[x * R + r]`` (which must hold -1), and
    ``pinned[x]`` set (the band's columns with a pin; ``band_forward``). Returns the
    number of pairs ``n``, whose ``(x, j, SER, VS)`` are
    ``pairs_row[:n]`` in increasing ``x`` (float32, ``(width, 4)``; rows from ``n`` on
    may be overwritten). No fill: the pinned band DP does it. Scratch:
    ``iwork`` (int64, (6 + levels, width), ``2**(levels - 1) >= width``), ``fwork``
    (float64, (4, width)), ``stack`` (int64, (width + 2, 6)).
    """
    ser_min, vs_max, vs_relative, var_floor, lr_check, uniqueness, edge_guard, steps = tests
    nr = BAND_ROWS
    nk = (ndisp + 2) * nr
    cand_x = iwork[0]
    held = iwork[1]
    cand_k = iwork[2]
    lr_j = iwork[3]
    lr_below = iwork[4]
    lr_above = iwork[5]
    cand_ser = fwork[0]
    cand_vs = fwork[1]
    cand_var = fwork[2]
    cand_live = fwork[3]
    sparse = iwork[6:]
    # the survivors of the cheap tests (band_feature_mask), in order, without branches
    m = 0
    for p in range(radius, width - radius):
        cand_x[m] = p
        m += keep[p * nr + r]
    # SER's scaled SSD: with steps**2 a power of two, total / (ssd / scale) is
    # (total * scale) / ssd exactly (both scalings are exact), one division fewer
    scale = float(steps * steps)
    exact_scale = (steps * steps) & (steps * steps - 1) == 0
    # whether the candidates that pass VS and SER are in order: their right pixels
    # strictly increasing with x (the mask's range test put each inside the windows), and
    # no left-right check, which can hold a candidate back
    ordered = not lr_check
    j_last = -1
    n = 0
    n_win = (2 * radius + 1) ** 2
    norm = float(n_win) * float(n_win) * float(steps) * float(steps)
    # the SSD and the right window's sums of every candidate, in a pass of their own (many
    # candidates' loads in flight) and in the form the window and the signals allow (sums
    # to cand_live, lr_below and lr_above, scratch until the search)
    if short_ssd:
        _candidate_sums(left_p, right_p, y, r, dmin, radius, cand_x, wta_k, m, cand_live,
                        lr_below, lr_above, SSD_SHORT)  # fmt: skip
    else:
        _candidate_sums(left_p, right_p, y, r, dmin, radius, cand_x, wta_k, m, cand_live,
                        lr_below, lr_above, SSD_WIDE)  # fmt: skip
    # VS and SER of every candidate, without branches (whether each passes to held) ...
    for q in range(m):
        v_l = var_l[cand_x[q] * nr + r]
        v_r = _window_variance(lr_below[q], lr_above[q], n_win, norm)
        vs = _variance_similarity(v_l, v_r, vs_relative)
        total = v_l + v_r
        ssd = cand_live[q]
        if exact_scale:
            ser = (total * scale) / ssd if ssd > 0 else np.inf
        else:
            ser = total / (ssd / scale) if ssd > 0 else np.inf
        cand_ser[q] = ser
        cand_vs[q] = vs
        cand_var[q] = v_l
        held[q] = (vs <= vs_max) & (ser >= ser_min)
    # ... and those that pass, moved to the front in order (each writes the next entry, and
    # only one that passes keeps it)
    for q in range(m):
        p = cand_x[q]
        best_k = wta_k[p * nr + r]
        j = p - dmin - best_k
        passed = held[q] != 0
        cand_x[n] = p
        cand_k[n] = best_k
        cand_ser[n] = cand_ser[q]
        cand_vs[n] = cand_vs[q]
        cand_var[n] = cand_var[q]
        ordered &= (j > j_last) | (not passed)
        j_last = j if passed else j_last
        n += passed
    if ordered:
        # then the search accepts every candidate, and none is tried twice: each is the
        # strongest of the interval between the stronger pairs around it, whose right
        # pixels bound its own on both sides. So the pins are set here and the work list
        # starts empty (no sparse table: most rows of the Middlebury scenes with the
        # default tests, where a row rejects 0.1 on average)
        for i in range(n):
            p = cand_x[i]
            pins[p * nr + r] = p - dmin - cand_k[i]
            pinned[p] = True
    else:
        for i in range(n):
            cand_live[i] = cand_var[i]
            lr_j[i] = -1
        _sparse_build(cand_var, n, sparse)
    # the work list holds only intervals with room and candidates: each push writes the
    # next entry and keeps it only then (no branch; an empty interval was a push, a pop
    # and a mispredicted test)
    stack[0, 0] = -1
    stack[0, 1] = width
    stack[0, 2] = -1
    stack[0, 3] = width
    stack[0, 4] = 0
    stack[0, 5] = n - 1
    top = _worth_splitting(-1, width, -1, width, 0, n - 1) & int(not ordered)
    while top > 0:
        top -= 1
        a = stack[top, 0]
        c = stack[top, 1]
        b = stack[top, 2]
        e = stack[top, 3]
        i_lo = stack[top, 4]
        i_hi = stack[top, 5]
        nheld = 0
        while True:
            i = _sparse_best(cand_var, sparse, i_lo, i_hi)
            if not cand_live[i] > -np.inf:
                i = -1
                strongest = -np.inf
                for q in range(i_lo, i_hi + 1):
                    if cand_live[q] > strongest:
                        strongest = cand_live[q]
                        i = q
            if i < 0:
                break
            p = cand_x[i]
            cand_live[i] = -np.inf
            k_lo = max(0, p - min(e - 1, width - 1 - radius) - dmin)
            k_hi = min(ndisp - 1, p - max(b + 1, radius) - dmin)
            best_k = cand_k[i]
            if not k_lo <= best_k <= k_hi:
                continue  # the sub-problems' ranges nest: retired
            j = p - dmin - best_k
            if lr_check:
                best = cost[p * nk + (best_k + 1) * nr + r]
                if lr_j[i] != j:
                    # the other left pixels x of the interval whose cost with j is at most
                    # best: the nearest on each side of p, or the interval's ends, a and c
                    # (selects: the loads do not wait on branches). Only hits inside (a, c)
                    # decide, here and in every later try of this candidate: it is tried
                    # again only in the sub-intervals of this one.
                    lr_j[i] = j
                    below = a
                    above = c
                    k0 = max(0, -(j + dmin), a + 1 - j - dmin)
                    k1 = min(ndisp, width - j - dmin, c - j - dmin)
                    o = np.uint64((j + dmin + k0) * nk + (k0 + 1) * nr + r)
                    for k in range(k0, k1):
                        x = j + dmin + k
                        hit = cost[o] <= best
                        below = x if hit & (x < p) else below
                        above = min(above, x) if hit & (x > p) else above
                        o += np.uint64(nk + nr)
                    lr_below[i] = below
                    lr_above[i] = above
                if lr_below[i] > a or lr_above[i] < c:
                    held[nheld] = i  # a narrower interval may let it pass
                    nheld += 1
                    continue
            pins[p * nr + r] = j
            pinned[p] = True
            stack[top, 0] = a
            stack[top, 1] = p
            stack[top, 2] = b
            stack[top, 3] = j
            stack[top, 4] = i_lo
            stack[top, 5] = i - 1
            top += _worth_splitting(a, p, b, j, i_lo, i - 1)
            stack[top, 0] = p
            stack[top, 1] = c
            stack[top, 2] = j
            stack[top, 3] = e
            stack[top, 4] = i + 1
            stack[top, 5] = i_hi
            top += _worth_splitting(p, c, j, e, i + 1, i_hi)
            break
        for h in range(nheld):
            cand_live[held[h]] = cand_var[held[h]]
    # the accepted candidates, in increasing x (as cand_x), without branches: each writes
    # the next row, and only an accepted one keeps it
    found = 0
    for i in range(n):
        p = cand_x[i]
        j = pins[p * nr + r]
        pairs_row[found, 0] = p
        pairs_row[found, 1] = j
        pairs_row[found, 2] = cand_ser[i]
        pairs_row[found, 3] = cand_vs[i]
        found += j >= 0
    return found


# --------------------------------------------------------------------------- drivers

#: The stages of ``match_band_rows`` that its ``clock`` times, in that order (``costs``:
#: the band's cost array, made before the search, and in ``dc`` the block match of the
#: columns it moves down a row; in free mode the forward pass makes the costs, in mode 3
#: the block match and the forward pass do; ``block match``: the other columns', with
#: ``band_strong_counts``; ``search``: the feature pairs of the band's rows, or its pins
#: read from ``partner``, and the pinned columns).
CLOCK_STAGES = (
    "signals", "costs", "variances", "block match", "mask", "search", "forward", "backtrack",
)  # fmt: skip
(
    _CLOCK_SIGNALS, _CLOCK_COSTS, _CLOCK_VARIANCES, _CLOCK_BLOCK, _CLOCK_MASK, _CLOCK_SEARCH,
    _CLOCK_FORWARD, _CLOCK_BACKTRACK,
) = range(len(CLOCK_STAGES))  # fmt: skip


@intrinsic
def _cycle_counter(typingctx):
    """Read the processor's cycle counter (``llvm.readcyclecounter``: the TSC on x86)."""

    def codegen(context, builder, sig, args):
        counter = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(_I64, []), "llvm.readcyclecounter"
        )
        return builder.call(counter, [])

    return types.int64(), codegen


def cycle_counter():
    """Plain Python's stand-in for the cycle counter (``NUMBA_DISABLE_JIT``): nanoseconds."""
    return time.perf_counter_ns()


@overload(cycle_counter)
def _cycle_counter_compiled():
    return lambda: _cycle_counter()


@nb.njit(cache=True, inline="always")
def _clock_mark(clock):
    """Return the counter now, or 0 without a clock (``clock`` None: nothing is compiled)."""
    if clock is None:
        return 0
    return cycle_counter()


@nb.njit(cache=True, inline="always")
def _clock_add(clock, ch, stage, mark):
    """Add the counts since ``mark`` to ``clock[ch, stage]``; return the counter now."""
    if clock is None:
        return 0
    now = cycle_counter()
    clock[ch, stage] += now - mark
    return now


@nb.njit(cache=True, inline="always")
def _chunk_lanes(height, nchunks, ch):
    """Return ``(y_a, n, run)``: chunk ``ch`` has ``n`` rows from ``y_a``.

    The ``ceil(height / R)`` bands are split as evenly as they go; lane ``r`` takes row
    ``y_a + r * run + t`` at band step ``t``.
    """
    nr = BAND_ROWS
    b0, b1 = _chunk_bounds((height + nr - 1) // nr, nchunks, ch)
    y_a = b0 * nr
    n = max(0, min(height, b1 * nr) - y_a)
    return y_a, n, (n + nr - 1) // nr


@nb.njit(cache=True, inline="always")
def _cost_scratch(width, ndisp, radius):
    """Return a chunk's scratch for the cost passes, in slots 0-5 of ``_placed``.

    ``(left_t, right_t, rows, spread, vs, hsum)``: ``band_lane_signals``' rows of the two
    views and their row numbers, and ``band_lane_costs``' scratch.
    """
    nr = BAND_ROWS
    width_p = width + 2 * radius
    nt = max(2 * radius + 1, 2)
    return (
        _placed(nt * width_p * nr, np.int32, 0),
        _placed(nt * width_p * nr, np.int32, 1),
        _placed(nt * nr, np.int64, 2),
        _placed(2 * ndisp * nr, np.int32, 3),
        _placed(width * ndisp * nr, np.int32, 4),
        _placed(ndisp * nr, np.int32, 5),
    )


@nb.njit(cache=True, inline="always")
def _lane_rows(t, y_a, run, n, radius, height_p, rows):
    """Write the padded rows ``band_lane_signals`` loads at band step ``t``; return how many.

    Lane ``r`` of a chunk of ``n`` rows from ``y_a`` takes row ``y_a + r * run + t`` (see
    ``match_band_rows``). At ``t = 0`` the ``2 radius + 1`` window rows of each lane's first
    row (past the image: any rows), then the row leaving and the row entering each lane's
    window (idle lanes: row 0).
    """
    nr = BAND_ROWS
    if t == 0:
        win = 2 * radius + 1
        for tt in range(win):
            for r in range(nr):
                rows[tt * nr + r] = min(y_a + r * run + tt, height_p - 1)
        return win
    for r in range(nr):
        if r * run + t < n:
            rows[r] = y_a + r * run + t - 1
            rows[nr + r] = y_a + r * run + t + 2 * radius
        else:
            rows[r] = 0
            rows[nr + r] = 0
    return 2


@nb.njit(cache=True, inline="always")
def _column_wta(cost, ndisp, keyed, scale, blocks, pre, low, first):
    """Find the least cost of each lane of one cost column and its first ``k`` (-1: all inf).

    ``cost`` is a column of ``_cost_column`` (``nk`` cells, the inf padding included);
    ``low[r]``/``first[r]`` get lane ``r``'s least cost and the first ``k`` that has it
    (``_kernels.match_block_rows``' strict ``<``). As in ``band_block_match``: the prefix
    minima along ``k`` in ``pre`` (one vector chain), over the keys ``cost * scale + (k +
    1)`` in the columns whose costs are all integers or inf (``keyed``; ``blocks[i]`` is
    ``k + 1`` of flat cell ``i``, ``scale`` a power of two above ``ndisp + 2``), where the
    least key carries the first index, and elsewhere over the costs, the first index then
    found by a binary search.
    """
    nr = BAND_ROWS
    unr = np.uint64(nr)
    nblocks = ndisp + 2
    top = np.uint64(nblocks * nr) - unr
    for i in range(unr):
        pre[i] = cost[i]  # the padding cells: inf (and inf is their key)
    if keyed:
        for i in range(top):
            p = unr + i
            pre[p] = min(pre[p - unr], cost[p] * scale + blocks[p])
    else:
        for i in range(top):
            p = unr + i
            pre[p] = min(pre[p - unr], cost[p])
    for r in range(nr):
        best = pre[(nblocks - 1) * nr + r]
        if not best < np.inf:
            low[r] = np.inf
            first[r] = -1
            continue
        if keyed:
            key = best
            best = np.floor(key * (1.0 / scale))
            b = int(key - best * scale)
        else:
            b = _first_reaching(pre, ndisp, r, best)
        low[r] = best
        first[r] = b - 1


@nb.njit(cache=True)
def _chunk_bounds(count, nchunks, c):
    # sizes differ by at most one, spread evenly: the parallel loop hands each thread an
    # equal run of chunks, so ceil-sized chunks (and a short last one) would leave one
    # thread more work (36 bands in 8 chunks: 20 against 16)
    return c * count // nchunks, (c + 1) * count // nchunks


@nb.njit(cache=True)
def _signal_bounds(left_p, right_p):
    """Return the least and the largest value of the two views (int64).

    Indexed loops in the views' own type: vector minima and maxima (on tsukuba's padded
    pair 19 us, against 36 us for the parallel reductions this replaced and 113 us for a
    loop over an iterator).
    """
    low = left_p[0, 0]
    high = low
    for view in (left_p, right_p):
        flat = view.ravel()
        for i in range(flat.size):
            low = min(low, flat[i])
            high = max(high, flat[i])
    return np.int64(low), np.int64(high)


@nb.njit(parallel=True, cache=True)
def match_band_rows(
    left_p,
    right_p,
    dmin,
    ndisp,
    radius,
    occ2,
    five,
    slant2,
    pin_mode,
    partner,
    tests,
    nchunks,
    disp,
    flags,
    total,
    pairs,
    counts,
    clock=None,
    bt=None,
    gcp=None,
):
    """Run the whole-scanline DP of every row, ``BAND_ROWS`` rows at a time.

    The results of ``_kernels.match_dsi_rows`` with ``bt=False``, bit for bit. The only
    parallel loop is over ``nchunks`` runs of consecutive rows (the ``ceil(height / R)``
    bands split as evenly as they go). In a chunk of ``n`` rows from ``y_a``, band row
    (lane) ``r`` runs down rows ``y_a + r * run + t``, ``run = ceil(n / R)``, at band step
    ``t``, so that each lane's row moves down by one from band to band and the vertical
    window sums are updated (``band_lane_costs``: two absolute differences per cell) after
    the chunk's first band (computed afresh). Lanes past the chunk's rows are idle: their
    sums stay those of their last row (or of clamped rows), no pins, results not written.

    ``pin_mode`` 0: no pins (``partner``, ``pairs``, ``counts`` and ``tests`` are not
    used). 1: ``partner[y, x] = j`` pins left pixel ``(y, x)`` to right
    pixel ``(y, j)`` (-1: no pin; along a row increasing in both ``x`` and ``j``, each pair
    inside the disparity range), and each row gets the result of ``_kernels.gcp_row``'s
    segment-by-segment DP through its pins, with the five- or three-step model (``five``).
    2: ``dc``: the pins are the reliable feature pairs of ``band_row_features`` (``tests``;
    the window variances of the two views from ``band_lane_variance``; ``partner`` is not
    used), and then as 1; the cost pass block-matches the columns it moves down a row as
    it makes them (``band_lane_costs``' ``match``) where the signals' span lets 32-bit keys
    hold every cost (``_keys_fit``), ``band_block_match`` the rest. Row ``y``'s
    ``counts[y]`` pairs are ``pairs[y, :counts[y]]`` (float32 ``(height, width, 4)``:
    ``x``, ``j``, SER, VS, in increasing ``x``; the rest of each row is scratch). 3: as
    2, without the band's cost array (for wide images and disparity ranges, whose band
    costs leave the caches): the block match makes the costs a column at a time
    (``band_block_match``'s ``make_costs``; the columns it moves down a row made and
    matched at once where the keys fit, its ``fused``) and the DP pass makes them again
    from the vertical sums it left. The search then has no costs to read: the left-right check
    (``tests[4]``) must be off.

    ``tests`` None (with ``pin_mode`` 0 only): the search and the band cost array are
    left out of the compiled function (numba prunes the ``tests is not None`` branches),
    so that ``dsi3`` and ``dsi5`` do not compile ``dc``'s code on their first call.

    ``clock`` None: not timed. Otherwise int64, ``(nchunks, len(CLOCK_STAGES))``: each
    chunk adds the cycle counts of its stages (``CLOCK_STAGES``) to its row (for
    ``benchmarks/bench_stages.py``; None compiles to the function without the counter).

    ``bt`` None: the SAD cost of eq. 4. Otherwise (``True``) the Birchfield-Tomasi cost
    (``band_lane_costs_bt``, the values of ``_kernels.row_costs_bt``), with ``pin_mode``
    0 to 2: the band's cost array is made first, and the search and the DP read it; its
    half-integer costs are never keyed (``band_block_match``'s generic pass). The results
    are those of ``_kernels.match_dsi_rows`` and ``match_dc_rows`` with ``bt=True`` (or
    ``gcp_row``'s DP through the pins), bit for bit. None compiles to the function
    without the BT code.

    ``gcp`` None: as above. Otherwise (``True``, with ``pin_mode`` 2 or 3) ``dsi3-gcp``: the
    pins of each row are its ground control points (``band_row_gcps``, the points of
    ``_kernels.select_gcps``; ``tests`` with the points' variance floor and uniqueness and
    no guard), written to ``partner`` (as ``_kernels.match_gcp_rows``; ``pairs`` and
    ``counts`` are not used), then as 1. Their left-right check walks the band's array in
    mode 2; in mode 3 it reads the two least costs of each right pixel, which the block
    match folds in as it makes each column (``band_block_match``' ``diagonals``). None
    compiles to the function without that search.
    """
    if bt is not None and pin_mode == 3:
        raise ValueError("the Birchfield-Tomasi cost needs the band's cost array (pin_mode 0-2)")
    if gcp is not None and pin_mode != 2 and pin_mode != 3:
        raise ValueError("the ground control points are a search (pin_mode 2 or 3)")
    height, width = disp.shape
    height_p, width_p = left_p.shape
    nr = BAND_ROWS
    nk = (ndisp + 2) * nr
    # the columns band_block_match's keyed search may take
    x_int_lo, x_int_hi = _integer_columns(width, dmin, ndisp, radius)
    if bt is not None:  # half-integer costs: no column is keyed
        x_int_hi = x_int_lo
    # dc: the pass that makes the costs (with the band's cost array, the cost pass; without,
    # the block match) block-matches these columns as it makes them (those it moves down a
    # row), where the 32-bit keys hold every cost
    key_shift = _key_shift(ndisp + 2)
    fused_hi = x_int_lo  # none
    short_ssd = False  # the search's SSD in its short form (SSD_SHORT)
    if tests is not None and (pin_mode == 2 or pin_mode == 3):
        # a loop, not the views' max() and min(): numba makes each array expression of a
        # parallel function a parallel loop of its own, seconds of compile
        low, high = _signal_bounds(left_p, right_p)
        span = high - low
        if _keys_fit(span, radius, key_shift):
            fused_hi = x_int_hi
        short_ssd = 2 * radius + 1 <= nr and _narrow_sums(span, max(abs(low), abs(high)), radius)
    for ch in nb.prange(nchunks):
        # the chunk's rows; lane r takes rows y_a + r * run + t at band step t
        y_a, n, run = _chunk_lanes(height, nchunks, ch)
        # scratch at chosen offsets within a page (see _placed), one slot per array
        left_t, right_t, rows, spread, vs, hsum = _cost_scratch(width, ndisp, radius)
        anchored = pin_mode > 0
        search = pin_mode >= 2
        made = pin_mode != 1 and pin_mode != 2  # no band cost array
        if bt is not None:
            made = False
            bt_bounds = _placed(12 * width_p * nr, np.int32, 28).reshape((12, width_p * nr))
            bt_spread = _placed(3 * ndisp * nr, np.int32, 29)
        # free mode and mode 3 make each column's costs inside the passes: two columns
        cost = _placed((2 if made else width) * nk, np.float64, 6)
        step_bits = _placed(width * (ndisp + 2), np.uint32, 7)
        ring = _placed(3 * nk, np.float64, 9).reshape((3, nk))
        ends = _placed(2 * ndisp * nr, np.float64, 10)
        # no fill: free mode reads neither, and the anchored modes write both each band
        pins = _placed(width * nr, np.int64, 11)
        pinned = _placed(width, np.bool_, 12)
        anchor_total = _placed(width * nr, np.float64, 13)
        anchor_steps = _placed(width * nr, np.int64, 14)
        anchor_x = np.empty(width, dtype=np.int64)
        nwork = width if search else 1
        pre = _placed(nk if search else 1, np.float64, 15)
        suf = _placed(nk if search else 1, np.float64, 16)
        wta_k = _placed(nwork * nr, np.int64, 17)
        wta_ratio = _placed(nwork * nr, np.float64, 18)
        keep = _placed(nwork * nr, np.uint8, 19)
        nvar = width_p * nr if search else 1
        colsum = _placed(nvar, np.float64, 20)
        colsq = _placed(nvar, np.float64, 21)
        hwork = _placed(2 * nwork * nr, np.float64, 22).reshape((2, nwork * nr))
        var_band = _placed(nwork * nr, np.float64, 23)
        steps = 1 if tests is None else tests[7]
        levels = 1
        while (1 << (levels - 1)) < width:
            levels += 1
        iwork = _placed((6 + levels) * nwork, np.int64, 24).reshape((6 + levels, nwork))
        fwork = _placed(4 * nwork, np.float64, 25).reshape((4, nwork))
        stack = _placed((nwork + 2) * 6, np.int64, 26).reshape((nwork + 2, 6))
        strong = _placed(nwork + 1, np.int64, 8)
        done = _placed(width, np.uint8, 27)  # columns the cost pass matched
        # dsi3-gcp's left-right check without the band's array (None for dc: a variable of
        # one type per compiled version, so that each compiles one form of the block match;
        # numba prunes a test of gcp only where it is None, and the gcp version compiled
        # both forms, 20 s more on its first call)
        diagonals = _gcp_scratch(gcp, nwork * nr if made else 1)
        for t in range(run):
            mark = _clock_mark(clock)
            nt = _lane_rows(t, y_a, run, n, radius, height_p, rows)
            band_lane_signals(left_p, right_p, rows, nt, left_t, right_t)
            mark = _clock_add(clock, ch, _CLOCK_SIGNALS, mark)
            if bt is not None:
                band_lane_costs_bt(
                    left_t, right_t, width, dmin, ndisp, radius, bt_bounds, bt_spread, vs,
                    t > 0, hsum, cost,
                )  # fmt: skip
                if search:
                    for x in range(width):
                        done[x] = 0  # the block match takes every column
                mark = _clock_add(clock, ch, _CLOCK_COSTS, mark)
            elif tests is not None and not made:  # the search and pins read them before the DP
                band_lane_costs(
                    left_t, right_t, width, dmin, ndisp, radius, spread, vs, int(t > 0), hsum,
                    cost, (x_int_lo, fused_hi, key_shift, wta_k, wta_ratio, done),
                )  # fmt: skip
                mark = _clock_add(clock, ch, _CLOCK_COSTS, mark)
            if tests is not None and search:
                band_lane_variance(
                    left_t, width, radius, steps, t > 0, colsum, colsq, hwork[0], hwork[1],
                    var_band,
                )  # fmt: skip
                mark = _clock_add(clock, ch, _CLOCK_VARIANCES, mark)
                # the block match only where the feature tests read it
                band_strong_counts(var_band, width, tests[3], strong)
                wanted = (strong, _guard_columns(tests[6]))
                if made:
                    band_block_match(
                        cost, width, ndisp, x_int_lo, x_int_hi, pre, suf, wta_k, wta_ratio,
                        (left_t, right_t, dmin, radius, spread, vs, int(t > 0), hsum), wanted,
                        None, (x_int_lo, fused_hi, key_shift), diagonals,
                    )  # fmt: skip
                else:
                    band_block_match(
                        cost, width, ndisp, x_int_lo, x_int_hi, pre, suf, wta_k, wta_ratio, None,
                        wanted, done,
                    )  # fmt: skip
                mark = _clock_add(clock, ch, _CLOCK_BLOCK, mark)
                band_feature_mask(var_band, wta_k, wta_ratio, width, dmin, radius, tests, keep)
                mark = _clock_add(clock, ch, _CLOCK_MASK, mark)
                for i in range(width * nr):
                    pins[i] = -1
                for x in range(width):
                    pinned[x] = False
                for r in range(nr):
                    if r * run + t >= n:
                        continue
                    y = y_a + r * run + t
                    if gcp is not None:
                        for x in range(width):
                            partner[y, x] = -1
                        band_row_gcps(
                            cost, width, ndisp, r, dmin, radius, wta_k, keep, iwork, pins,
                            pinned, partner[y], diagonals, made,
                        )  # fmt: skip
                        continue
                    counts[y] = band_row_features(
                        cost,
                        width,
                        ndisp,
                        r,
                        dmin,
                        radius,
                        left_p,
                        right_p,
                        y,
                        var_band,
                        wta_k,
                        keep,
                        tests,
                        short_ssd,
                        iwork,
                        fwork,
                        stack,
                        pins,
                        pinned,
                        pairs[y],
                    )
            elif anchored:
                for x in range(width):
                    for r in range(nr):
                        pins[x * nr + r] = partner[y_a + r * run + t, x] if r * run + t < n else -1
                for x in range(width):
                    pinned[x] = False
                    for r in range(nr):
                        if pins[x * nr + r] >= 0:
                            pinned[x] = True
            if anchored:
                mark = _clock_add(clock, ch, _CLOCK_SEARCH, mark)
            # two call sites: the forward pass with the band's costs, and the one that
            # makes them (a None or a tuple argument: two compiled versions); after the
            # block match of mode 3 the band's vertical sums are ready
            if bt is not None:
                band_forward(
                    cost, width, dmin, ndisp, occ2, five, slant2, anchored, pins, pinned,
                    anchor_total, anchor_steps, ring, step_bits, ends, None,
                )  # fmt: skip
            elif tests is not None and not made:
                band_forward(
                    cost, width, dmin, ndisp, occ2, five, slant2, True, pins, pinned,
                    anchor_total, anchor_steps, ring, step_bits, ends, None,
                )  # fmt: skip
            else:
                band_forward(
                    cost, width, dmin, ndisp, occ2, five, slant2, anchored, pins, pinned,
                    anchor_total, anchor_steps, ring, step_bits, ends,
                    (left_t, right_t, radius, spread, vs, SUMS_READY if search else int(t > 0),
                     hsum),
                )  # fmt: skip
            mark = _clock_add(clock, ch, _CLOCK_FORWARD, mark)
            for r in range(nr):
                if r * run + t >= n:
                    continue
                y = y_a + r * run + t
                for x in range(width):
                    disp[y, x] = np.nan
                    flags[y, x] = FLAG_BORDER
                # the row's anchor columns: its pairs, or the pins given (a scan without
                # branches: each column writes the next entry, a pinned one keeps it)
                nanchors = 0
                if search and gcp is None:
                    nanchors = counts[y]
                    for i in range(nanchors):
                        anchor_x[i] = np.int64(pairs[y, i, 0])
                elif anchored:
                    for x in range(width):
                        anchor_x[nanchors] = x
                        nanchors += pins[x * nr + r] >= 0
                total[y] = band_backtrack_row(
                    step_bits,
                    ends,
                    width,
                    dmin,
                    ndisp,
                    r,
                    anchor_x,
                    nanchors,
                    pins,
                    anchor_total,
                    anchor_steps,
                    disp[y],
                    flags[y],
                )
            _clock_add(clock, ch, _CLOCK_BACKTRACK, mark)


@nb.njit(parallel=True, cache=True)
def match_block_bands(left_p, right_p, dmin, ndisp, radius, nchunks, disp, flags, total, bt=None):
    """Winner-take-all block matching, ``BAND_ROWS`` rows at a time.

    The results of ``_kernels.match_block_rows``, bit for bit: per pixel the first
    disparity of least window cost (NaN and ``FLAG_BORDER`` where every cell is inf), and
    per row the sum of the least costs in ``x`` order. The chunks and lanes are those of
    ``match_band_rows``. SAD (``bt`` None): each column's costs are made as in its free
    mode (``_cost_column``) and matched at once (``_column_wta``, the prefix minima of
    ``band_block_match``), so no band cost array is kept. Birchfield-Tomasi (``bt``
    True): the band's cost array is made first (``band_lane_costs_bt``) and its columns
    matched, never keyed (half-integer costs).
    """
    height, width = disp.shape
    height_p = left_p.shape[0]
    width_p = width + 2 * radius
    nr = BAND_ROWS
    nk = (ndisp + 2) * nr
    x_int_lo, x_int_hi = _integer_columns(width, dmin, ndisp, radius)  # keyed columns
    if bt is not None:
        x_int_hi = x_int_lo
    for ch in nb.prange(nchunks):
        y_a, n, run = _chunk_lanes(height, nchunks, ch)
        left_t, right_t, rows, spread, vs, hsum = _cost_scratch(width, ndisp, radius)
        cost = _placed(nk, np.float64, 6)
        pre = _placed(nk, np.float64, 7)
        blocks = _placed(nk, np.float64, 8)
        scale = _key_blocks(ndisp, blocks)
        low = _placed(nr, np.float64, 9)
        first = _placed(nr, np.int64, 10)
        sums = _placed(nr, np.float64, 11)
        if bt is not None:
            band_cost = _placed(width * nk, np.float64, 12)
            bt_bounds = _placed(12 * width_p * nr, np.int32, 13).reshape((12, width_p * nr))
            bt_spread = _placed(3 * ndisp * nr, np.int32, 14)
        for t in range(run):
            nt = _lane_rows(t, y_a, run, n, radius, height_p, rows)
            band_lane_signals(left_p, right_p, rows, nt, left_t, right_t)
            if bt is not None:
                band_lane_costs_bt(
                    left_t, right_t, width, dmin, ndisp, radius, bt_bounds, bt_spread, vs,
                    t > 0, hsum, band_cost,
                )  # fmt: skip
            for r in range(nr):
                sums[r] = 0.0
            for x in range(width):
                keyed = x_int_lo <= x < x_int_hi
                if bt is not None:
                    _column_wta(
                        band_cost[x * nk : (x + 1) * nk], ndisp, keyed, scale, blocks, pre, low,
                        first,
                    )  # fmt: skip
                else:
                    _cost_column(
                        left_t, right_t, x, width, dmin, ndisp, radius, spread, vs, int(t > 0),
                        hsum, cost, np.uint64(0),
                    )  # fmt: skip
                    _column_wta(cost, ndisp, keyed, scale, blocks, pre, low, first)
                for r in range(nr):
                    if r * run + t >= n:
                        continue
                    y = y_a + r * run + t
                    if first[r] < 0:
                        disp[y, x] = np.nan
                        flags[y, x] = FLAG_BORDER
                    else:
                        disp[y, x] = dmin + first[r]
                        flags[y, x] = 0
                        sums[r] += low[r]
            for r in range(nr):
                if r * run + t < n:
                    total[y_a + r * run + t] = sums[r]
