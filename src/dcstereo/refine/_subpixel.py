"""Sub-pixel refinement (:mod:`dcstereo.refine.subpixel`): three costs and a fit at each pixel.

The costs are the run's: eq. 4's SAD, or the Birchfield-Tomasi dissimilarity summed over
the same window (``bt``; the values of ``costs.row_costs_bt``: doubled integers summed,
halved, then the truncated windows rescaled).
"""

import numba as nb
import numpy as np

from dcstereo.costs.window import _bt_cell2

#: ``fit`` of ``refine_rows``.
FIT_EQUIANGULAR = 0
FIT_PARABOLA = 1


@nb.njit(cache=True, inline="always")
def _column_sad(left_p, right_p, y, xp, e, win):
    """One column of eq. 4's window: rows ``y .. y + win - 1`` of padded column ``xp``."""
    total = 0
    for t in range(win):
        total += abs(left_p[y + t, xp] - right_p[y + t, xp - e])
    return total


@nb.njit(cache=True, inline="always")
def _bounds2(img_p, r, xp, lo, hi):
    """Return a padded pixel's doubled value and its doubled interpolation bounds.

    The least and largest of the doubled value and its two doubled half-pixel
    interpolations (a neighbour outside the image columns ``lo..hi`` is the pixel itself),
    as ``costs._bt_row_bounds``.
    """
    v = img_p[r, xp]
    twice = 2 * v
    minus = v + img_p[r, max(xp - 1, lo)]
    plus = v + img_p[r, min(xp + 1, hi)]
    return twice, min(twice, min(minus, plus)), max(twice, max(minus, plus))


@nb.njit(cache=True, inline="always")
def _bt2(l2, l_min, l_max, right_p, r, xr, lo, hi):
    """Twice the BT dissimilarity of a left pixel (its ``_bounds2``) and right pixel ``xr``.

    ``min(d_LR, d_RL)`` of ``costs._bt_cell2``.
    """
    r2, r_min, r_max = _bounds2(right_p, r, xr, lo, hi)
    return _bt_cell2(l2, l_min, l_max, r2, r_min, r_max)


@nb.njit(cache=True, inline="always")
def _column_bt2(left_p, right_p, y, xp, e, win, lo, hi):
    """Sum one column of the BT window, doubled: rows ``y .. y + win - 1``, ``xp - e``."""
    total = 0
    for t in range(win):
        l2, l_min, l_max = _bounds2(left_p, y + t, xp, lo, hi)
        total += _bt2(l2, l_min, l_max, right_p, y + t, xp - e, lo, hi)
    return total


@nb.njit(cache=True, inline="always")
def _three_columns(left_p, right_p, y, xp, d, win, bt, lo, hi):
    """One window column at disparities ``d - 1, d, d + 1``: SAD, or doubled BT with ``bt``.

    Each left pixel (and its BT bounds) is read once for the three.
    """
    c0 = 0
    c1 = 0
    c2 = 0
    for t in range(win):
        r = y + t
        if bt:
            l2, l_min, l_max = _bounds2(left_p, r, xp, lo, hi)
            c0 += _bt2(l2, l_min, l_max, right_p, r, xp - d + 1, lo, hi)
            c1 += _bt2(l2, l_min, l_max, right_p, r, xp - d, lo, hi)
            c2 += _bt2(l2, l_min, l_max, right_p, r, xp - d - 1, lo, hi)
        else:
            v = left_p[r, xp]
            c0 += abs(v - right_p[r, xp - d + 1])
            c1 += abs(v - right_p[r, xp - d])
            c2 += abs(v - right_p[r, xp - d - 1])
    return c0, c1, c2


@nb.njit(cache=True, inline="always")
def _column_cost(left_p, right_p, y, xp, e, win, bt, lo, hi):
    """One window column: SAD, or doubled BT with ``bt``."""
    if bt:
        return _column_bt2(left_p, right_p, y, xp, e, win, lo, hi)
    return _column_sad(left_p, right_p, y, xp, e, win)


@nb.njit(cache=True, inline="always")
def _window_cost(left_p, right_p, y, x, d, radius, width, bt=False):
    """Eq. 4 (or BT with ``bt``) at ``(y, x)`` and integer disparity ``d``, padded signals.

    As ``costs.row_costs`` (``row_costs_bt``): rows edge-replicated (the padding), the
    columns whose left or right pixel leaves its image skipped and the sum rescaled to the
    full window (BT: halved first); inf when no column is left.
    """
    win = 2 * radius + 1
    total = 0
    used = 0
    for s in range(-radius, radius + 1):
        xl = x + s
        xr = x - d + s
        if xl < 0 or xl >= width or xr < 0 or xr >= width:
            continue
        used += 1
        total += _column_cost(
            left_p, right_p, y, xl + radius, d, win, bt, radius, radius + width - 1
        )
    if used == 0:
        return np.inf
    value = total * 0.5 if bt else float(total)
    if used == win:
        return value
    return value * win / used


@nb.njit(cache=True, parallel=True)
def refine_rows(left_p, right_p, disparity, wanted, dmin, dmax, radius, fit, out, bt=False):
    """Write into ``out`` each wanted pixel's disparity moved by its fitted offset.

    ``out`` starts as a copy of ``disparity``. A wanted pixel has an integer disparity
    ``d`` with ``dmin < d < dmax``; with ``c0, c1, c2`` its costs at ``d - 1, d, d + 1``
    and ``c1`` the least of them (the path does not always take a cost's minimum), the
    offset is ``(c0 - c2) / (2 max(c0 - c1, c2 - c1))`` (``FIT_EQUIANGULAR``: two lines of
    opposite slopes through the three points, the fit suited to absolute differences) or
    ``(c0 - c2) / (2 (c0 - 2 c1 + c2))`` (``FIT_PARABOLA``), both within ``[-0.5, 0.5]``;
    a flat or non-minimal triple keeps ``d``. Returns nothing; rows run in parallel.

    Inside the images (every column of the three windows in both) the window sums are
    kept as integers per row: a pixel after one of the same ``d`` slides them by a column
    (the column leaving subtracted, the one entering added), others sum their window
    anew; near an edge :func:`_window_cost` applies its rules. The sums are exact either
    way, so the results do not depend on the order. ``bt``: the Birchfield-Tomasi cost
    (doubled integers in the sums, halved at the fit).
    """
    height, width = disparity.shape
    win = 2 * radius + 1
    lo = radius  # the image's columns, padded
    hi = radius + width - 1
    for y in nb.prange(height):
        run_x = -2  # the last pixel whose inside sums s0, s1, s2 are kept, and its d
        run_d = 0
        s0 = 0
        s1 = 0
        s2 = 0
        for x in range(width):
            if not wanted[y, x]:
                continue
            d = int(disparity[y, x])
            if d - 1 < dmin or d + 1 > dmax:
                continue
            inside = x - radius >= 0 and x + radius < width
            inside = inside and x - radius - d - 1 >= 0 and x + radius - d + 1 < width
            if inside and run_x == x - 1 and run_d == d:
                gone = x - 1  # padded column of the column x - 1 - radius
                new = x + 2 * radius  # padded column of x + radius
                a0, a1, a2 = _three_columns(left_p, right_p, y, new, d, win, bt, lo, hi)
                b0, b1, b2 = _three_columns(left_p, right_p, y, gone, d, win, bt, lo, hi)
                s0 += a0 - b0
                s1 += a1 - b1
                s2 += a2 - b2
            elif inside:
                s0 = 0
                s1 = 0
                s2 = 0
                for xp in range(x, x + win):
                    a0, a1, a2 = _three_columns(left_p, right_p, y, xp, d, win, bt, lo, hi)
                    s0 += a0
                    s1 += a1
                    s2 += a2
            if inside:
                run_x = x
                run_d = d
                half = 0.5 if bt else 1.0  # exact: BT sums are doubled integers
                c0 = s0 * half
                c1 = s1 * half
                c2 = s2 * half
            else:  # a window's column leaves an image: the edge rules of _window_cost
                run_x = -2
                c0 = _window_cost(left_p, right_p, y, x, d - 1, radius, width, bt)
                c1 = _window_cost(left_p, right_p, y, x, d, radius, width, bt)
                c2 = _window_cost(left_p, right_p, y, x, d + 1, radius, width, bt)
            if not (c1 <= c0 and c1 <= c2) or c2 == np.inf or c0 == np.inf:
                continue
            if fit == FIT_EQUIANGULAR:
                slope = max(c0 - c1, c2 - c1)
            else:
                slope = c0 - 2.0 * c1 + c2
            if slope <= 0.0:
                continue
            out[y, x] = np.float32(d + (c0 - c2) / (2.0 * slope))
