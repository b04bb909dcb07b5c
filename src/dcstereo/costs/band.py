"""Window costs of a band of ``BAND_ROWS`` scanlines: eq. 4's SAD and Birchfield-Tomasi.

The band layout: ``BAND_ROWS`` rows run together with the row as the innermost, contiguous
axis, so that every per-cell operation is one vector operation over the rows. The costs
of a band are ``out[x * nk + (k + 1) * R + r]`` (cell ``k`` of band row ``r`` in column
``x``; ``nk = (ndisp + 2) * R``, one inf padding cell on each side of the disparities):
the values of :mod:`.costs`' ``row_costs`` and ``row_costs_bt``, bit for bit.
``band_lane_costs`` makes a band's cost array, ``_cost_column`` one column at a time (for
the DP pass that keeps no array), ``band_lane_variance`` the window variances of a band.
The rows of a band are not consecutive (see :mod:`.bands`): each lane runs down its own
rows, so the integer vertical window sums move down one row per band.

Every hot loop is one flat loop over unsigned indices: numba wraps a negative signed index
around (a select per access, which turns vector loads into gathers), and it leaves LLVM's
SLP vectorizer off, so a fixed inner loop over the ``R`` rows would be unrolled into scalar
code. A flat loop over ``(k, r)`` is vectorized like any other.
"""

import numba as nb
import numpy as np

from dcstereo._vector.costs import _moved_costs, _moved_costs_keyed
from dcstereo._vector.simd import BAND_ROWS, _lane_rows_copy
from dcstereo.costs.window import _bt_cell2
from dcstereo.divide.features import _window_variance


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


#: How a band's vertical window sums stand as a cost pass starts (its ``incremental``; see
#: ``band_lane_costs``): made afresh from the window rows (the chunk's first band; False
#: works too), moved down a row from the band before (True works too), or already made by
#: an earlier pass over the same band (the block match of ``bands.SEARCH_TWICE``).
SUMS_AFRESH = 0
SUMS_MOVED = 1
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


@nb.njit(cache=True, inline="always")
def _movable(add, sub, width, dmin, ndisp, incremental):
    """Whether ``_moved_costs`` makes the column whose window gains ``add`` and loses ``sub``.

    Where the column's sums move down a row (``incremental`` ``SUMS_MOVED``), the window's entering
    column ``add`` and leaving column ``sub`` are inside the image, and every disparity of
    ``add`` has its right pixel inside the image.
    """
    return (
        incremental == SUMS_MOVED
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

    ``incremental`` ``SUMS_AFRESH``: ``left_t``/``right_t`` hold the ``2 radius + 1`` window
    rows of each lane (``band_lane_signals``) and the sums are computed afresh;
    ``SUMS_MOVED``: ``vs`` holds
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


@nb.njit(cache=True, inline="always")
def _bt_lane_bounds(sig_t, slot, width, radius, reverse, bounds, o_bounds):
    """Doubled values and half-pixel bounds of window row ``slot`` of every lane.

    ``sig_t`` as ``band_lane_signals`` lays a view out (``reverse``: the right view, stored
    right to left). ``bounds[o_bounds + 0/1/2]``, each ``width_p * R`` at the same places
    as the row's pixels: the doubled value and the least and largest of it and its two
    doubled half-pixel interpolations (``costs._bt_row_bounds``; a neighbour outside the
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

    The values of ``costs.row_costs_bt``, bit for bit: the doubled dissimilarities
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


@nb.njit(cache=True)
def band_lane_variance(sig_t, width, radius, steps, incremental, colsum, colsq, hsum, hsq, out):
    """Window variance of every pixel of the band's rows, in one view's band layout.

    ``sig_t`` is ``left_t`` or ``right_t`` of ``band_lane_signals`` (the rows as for
    ``band_lane_costs``); ``out[u * R + r]`` is the variance of the window at storage
    column ``u`` of lane ``r``: left pixel ``x = u``, right pixel ``x = width - 1 - u``
    (the right view is stored right to left). The values of ``features.window_variance_row``
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
