"""Window costs of one scanline: eq. 4's SAD and the Birchfield-Tomasi dissimilarity.

``row_costs`` makes the banded DSI of one row, ``cost[x, k]`` for ``d = dmin + k`` (eq. 4,
section 3: the window sum of absolute differences), from vertical window sums kept from
row to row; ``row_costs_bt`` the same with Birchfield and Tomasi's sampling-insensitive
dissimilarity. The band forms (``BAND_ROWS`` rows at a time) are in :mod:`.band_costs`,
bit for bit the same values.
"""

import numba as nb
import numpy as np


@nb.njit(cache=True)
def row_costs(left_p, right_p, y, dmin, ndisp, radius, vcol, out, incremental):
    """Windowed SAD of eq. 4 for row ``y`` into ``out[x, k]`` (inf outside the image).

    ``left_p``/``right_p`` are the integer signals padded by ``radius`` on every side
    (edge replicated): padded row ``y + t``, ``t in [0, 2 * radius]``, is row ``y - radius + t``
    of the window, replicated identically in both views. Along the row the window is
    *truncated* to the columns ``s`` where both ``x + s`` and ``x - d + s`` lie inside the
    images, and the sum is rescaled to the full window (``* W / columns used``): padding one
    view and comparing it with real pixels of the other would charge a fake mismatch to the
    pixels within ``radius`` of an image edge. Interior cells are exact integer sums.

    ``vcol`` (int32, shape (width, ndisp): room for windows of 500,000 rows) holds the
    vertical window sums ``sum_t |L(y + t, x) - R(y + t, x - d)|`` of every cell; with
    ``incremental`` it must hold those of row ``y - 1`` (the previous call) and is updated
    by adding the row that enters the window and subtracting the one that leaves it (two
    absolute differences per cell instead of ``W``); otherwise it is computed afresh. The
    horizontal sum then runs along ``x`` for all disparities at once (the inner loop is
    over ``k``, contiguous).
    """
    wp = left_p.shape[1]
    width = wp - 2 * radius
    win = 2 * radius + 1
    # vertical sums; cells whose partner lies outside the right image hold 0
    if incremental:
        top = y - 1  # padded row leaving the window
        bottom = y + 2 * radius  # padded row entering it
        for x in range(width):
            lt = left_p[top, x + radius]
            lb = left_p[bottom, x + radius]
            base = x - dmin + radius
            k_lo = max(0, x - dmin - (width - 1))
            k_hi = min(ndisp - 1, x - dmin)
            for k in range(k_lo, k_hi + 1):
                jp = base - k
                vcol[x, k] += abs(lb - right_p[bottom, jp]) - abs(lt - right_p[top, jp])
    else:
        for x in range(width):
            for k in range(ndisp):
                vcol[x, k] = 0
            base = x - dmin + radius
            k_lo = max(0, x - dmin - (width - 1))
            k_hi = min(ndisp - 1, x - dmin)
            for t in range(win):
                lv = left_p[y + t, x + radius]
                for k in range(k_lo, k_hi + 1):
                    vcol[x, k] += abs(lv - right_p[y + t, base - k])
    _window_sums(vcol, out, width, dmin, ndisp, radius, False)


@nb.njit(cache=True, inline="always")
def _window_sums(vcol, out, width, dmin, ndisp, radius, halve):
    """Finish a row's window costs from its vertical sums ``vcol`` into ``out[x, k]``.

    The horizontal sums run along ``x`` for every ``k`` at once (the inner loop is over
    ``k``, contiguous; the cells outside the right image hold 0 in ``vcol``); ``halve``
    halves them (exact: they are integers) for the doubled Birchfield-Tomasi values, then
    the cells outside the image get ``inf`` and the truncated windows near the ends of
    each disparity's range are rescaled to the full window (``* W / columns used``;
    halving first changes no bit, a power of two commutes with the rounding).
    """
    win = 2 * radius + 1
    for k in range(ndisp):
        out[0, k] = 0.0
    for c in range(min(radius, width - 1) + 1):
        for k in range(ndisp):
            out[0, k] += vcol[c, k]
    for x in range(1, width):
        add = x + radius
        sub = x - radius - 1
        if add < width and sub >= 0:
            for k in range(ndisp):
                out[x, k] = out[x - 1, k] + (vcol[add, k] - vcol[sub, k])
        elif add < width:
            for k in range(ndisp):
                out[x, k] = out[x - 1, k] + vcol[add, k]
        elif sub >= 0:
            for k in range(ndisp):
                out[x, k] = out[x - 1, k] - vcol[sub, k]
        else:
            for k in range(ndisp):
                out[x, k] = out[x - 1, k]
    if halve:
        for x in range(width):
            for k in range(ndisp):
                out[x, k] *= 0.5
    for k in range(ndisp):
        d = dmin + k
        x0 = max(0, d)
        x1 = min(width, width + d)  # exclusive; 0 <= x - d < width
        for x in range(0, min(x0, width)):
            out[x, k] = np.inf
        for x in range(max(x1, 0), width):
            out[x, k] = np.inf
        # only the first and last ``radius`` columns of the range have truncated windows
        lo_end = min(x0 + radius, x1)
        hi_start = max(x1 - radius, lo_end)
        for x in range(x0, lo_end):
            used = min(x + radius, x1 - 1) - max(x - radius, x0) + 1
            if used != win:
                out[x, k] = out[x, k] * win / used
        for x in range(hi_start, x1):
            used = min(x + radius, x1 - 1) - max(x - radius, x0) + 1
            if used != win:
                out[x, k] = out[x, k] * win / used


@nb.njit(cache=True, inline="always")
def _bt_cell2(l2, l_min, l_max, r2, r_min, r_max):
    """Twice the Birchfield-Tomasi dissimilarity of a left and a right pixel.

    From each pixel's doubled value and the least and largest of it and its two doubled
    half-pixel interpolations (:func:`_bt_row_bounds`; doubled, ``(I[x] + I[x +- 1]) / 2``
    is the integer ``I[x] + I[x +- 1]``). In int32 throughout: numba would widen each
    difference to int64, halving the lanes of the band kernels' vector loop (the doubled
    signals and their differences fit 32 bits).
    """
    zero = np.int32(0)
    d_lr = max(zero, max(np.int32(l2 - r_max), np.int32(r_min - l2)))
    d_rl = max(zero, max(np.int32(r2 - l_max), np.int32(l_min - r2)))
    return min(d_lr, d_rl)


@nb.njit(cache=True, inline="always")
def _bt_row_bounds(img_p, r, lo, hi, v2, v_min, v_max, reverse=False):
    """Fill a padded row's doubled values and their interpolation bounds, columns ``lo..hi``.

    ``v2`` the doubled value, ``v_min``/``v_max`` the least and largest of it and the two
    doubled half-pixel interpolations (a neighbour outside ``lo..hi``, the image's padded
    columns, is the pixel itself). ``reverse``: column ``xp``'s at ``len(v2) - 1 - xp``.
    """
    last = v2.shape[0] - 1
    for xp in range(lo, hi + 1):
        v = img_p[r, xp]
        twice = 2 * v
        minus = v + img_p[r, max(xp - 1, lo)]
        plus = v + img_p[r, min(xp + 1, hi)]
        i = last - xp if reverse else xp
        v2[i] = twice
        v_min[i] = min(twice, min(minus, plus))
        v_max[i] = max(twice, max(minus, plus))


@nb.njit(cache=True, inline="always")
def _bt_bounds_buffers(wp):
    """Six int32 rows of ``wp``: a view's values and bounds for two padded rows."""
    return (
        np.empty(wp, dtype=np.int32), np.empty(wp, dtype=np.int32),
        np.empty(wp, dtype=np.int32), np.empty(wp, dtype=np.int32),
        np.empty(wp, dtype=np.int32), np.empty(wp, dtype=np.int32),
    )  # fmt: skip


@nb.njit(cache=True)
def row_costs_bt(left_p, right_p, y, dmin, ndisp, radius, vcol, out, incremental):
    """Windowed Birchfield-Tomasi dissimilarity of row ``y`` into ``out[x, k]``.

    The contract of ``row_costs`` (same arguments, padded inputs, band, ``inf`` outside
    the image, window truncated at the image edges and rescaled to ``W`` columns, ``vcol``
    kept across the rows of a chunk with ``incremental``), with the per-pixel absolute
    difference replaced by the sampling-insensitive dissimilarity of Birchfield and
    Tomasi (1998): ``min(d_LR, d_RL)`` with
    ``d_LR = max(0, I_L(x) - I_R^max, I_R^min - I_L(x))``, where ``I_R^min/max`` are
    the least and largest of the linearly interpolated right values at ``j - 1/2``,
    ``j`` and ``j + 1/2`` (``j = x - d``), and ``d_RL`` symmetrically. At the image's
    first and last columns the missing neighbour is the pixel itself. ``vcol`` holds
    *doubled* dissimilarities (exact integers); ``out`` is halved at the end, so its
    units are those of ``row_costs`` (half-integers, still exact in float64).
    """
    wp = left_p.shape[1]
    width = wp - 2 * radius
    win = 2 * radius + 1
    lo = radius
    hi = radius + width - 1
    # each padded row's doubled values and their least and largest doubled half-pixel
    # interpolations, made once per row instead of once per cell
    l2, l_min, l_max, l2b, l_minb, l_maxb = _bt_bounds_buffers(wp)
    r2, r_min, r_max, r2b, r_minb, r_maxb = _bt_bounds_buffers(wp)
    if incremental:
        top = y - 1
        bottom = y + 2 * radius
        _bt_row_bounds(left_p, top, lo, hi, l2, l_min, l_max)
        _bt_row_bounds(right_p, top, lo, hi, r2, r_min, r_max, True)
        _bt_row_bounds(left_p, bottom, lo, hi, l2b, l_minb, l_maxb)
        _bt_row_bounds(right_p, bottom, lo, hi, r2b, r_minb, r_maxb, True)
        for x in range(width):
            xp = x + radius
            lb2, lbmin, lbmax = l2b[xp], l_minb[xp], l_maxb[xp]
            lt2, ltmin, ltmax = l2[xp], l_min[xp], l_max[xp]
            rbase = wp - 1 - (x - dmin + radius)  # reversed: k increasing reads forward
            k_lo = max(0, x - dmin - (width - 1))
            k_hi = min(ndisp - 1, x - dmin)
            for k in range(k_lo, k_hi + 1):
                i = rbase + k
                vcol[x, k] += _bt_cell2(
                    lb2, lbmin, lbmax, r2b[i], r_minb[i], r_maxb[i]
                ) - _bt_cell2(lt2, ltmin, ltmax, r2[i], r_min[i], r_max[i])
    else:
        for x in range(width):
            for k in range(ndisp):
                vcol[x, k] = 0
        for t in range(win):
            _bt_row_bounds(left_p, y + t, lo, hi, l2, l_min, l_max)
            _bt_row_bounds(right_p, y + t, lo, hi, r2, r_min, r_max, True)
            for x in range(width):
                xp = x + radius
                lv2, lvmin, lvmax = l2[xp], l_min[xp], l_max[xp]
                rbase = wp - 1 - (x - dmin + radius)
                k_lo = max(0, x - dmin - (width - 1))
                k_hi = min(ndisp - 1, x - dmin)
                for k in range(k_lo, k_hi + 1):
                    i = rbase + k
                    vcol[x, k] += _bt_cell2(lv2, lvmin, lvmax, r2[i], r_min[i], r_max[i])
    _window_sums(vcol, out, width, dmin, ndisp, radius, True)


@nb.njit(cache=True)
def _row_costs_any(left_p, right_p, y, dmin, ndisp, radius, vcol, out, incremental, bt):
    """``row_costs_bt`` when ``bt``, else ``row_costs`` (the windowed SAD of eq. 4)."""
    if bt:
        row_costs_bt(left_p, right_p, y, dmin, ndisp, radius, vcol, out, incremental)
    else:
        row_costs(left_p, right_p, y, dmin, ndisp, radius, vcol, out, incremental)
