"""Compiled kernel of ``subpixel.py``: three window costs and a fit at every pixel."""

import numba as nb
import numpy as np

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
def _window_sad(left_p, right_p, y, x, d, radius, width):
    """Eq. 4 at ``(y, x)`` and integer disparity ``d`` on the padded signals.

    As ``_kernels.row_costs``: rows edge-replicated (the padding), the columns whose left
    or right pixel leaves its image skipped and the sum rescaled to the full window; inf
    when no column is left.
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
        total += _column_sad(left_p, right_p, y, xl + radius, d, win)
    if used == 0:
        return np.inf
    if used == win:
        return float(total)
    return total * win / used


@nb.njit(cache=True, parallel=True)
def refine_rows(left_p, right_p, disparity, wanted, dmin, dmax, radius, fit, out):
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
    anew; near an edge :func:`_window_sad` applies its rules. The sums are exact either
    way, so the results do not depend on the order.
    """
    height, width = disparity.shape
    win = 2 * radius + 1
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
                s0 += _column_sad(left_p, right_p, y, new, d - 1, win)
                s0 -= _column_sad(left_p, right_p, y, gone, d - 1, win)
                s1 += _column_sad(left_p, right_p, y, new, d, win)
                s1 -= _column_sad(left_p, right_p, y, gone, d, win)
                s2 += _column_sad(left_p, right_p, y, new, d + 1, win)
                s2 -= _column_sad(left_p, right_p, y, gone, d + 1, win)
            elif inside:
                s0 = 0
                s1 = 0
                s2 = 0
                for xp in range(x, x + win):
                    s0 += _column_sad(left_p, right_p, y, xp, d - 1, win)
                    s1 += _column_sad(left_p, right_p, y, xp, d, win)
                    s2 += _column_sad(left_p, right_p, y, xp, d + 1, win)
            if inside:
                run_x = x
                run_d = d
                c0 = float(s0)
                c1 = float(s1)
                c2 = float(s2)
            else:  # a window's column leaves an image: the edge rules of _window_sad
                run_x = -2
                c0 = _window_sad(left_p, right_p, y, x, d - 1, radius, width)
                c1 = _window_sad(left_p, right_p, y, x, d, radius, width)
                c2 = _window_sad(left_p, right_p, y, x, d + 1, radius, width)
            if not (c1 <= c0 and c1 <= c2) or c2 == np.inf or c0 == np.inf:
                continue
            if fit == FIT_EQUIANGULAR:
                slope = max(c0 - c1, c2 - c1)
            else:
                slope = c0 - 2.0 * c1 + c2
            if slope <= 0.0:
                continue
            out[y, x] = np.float32(d + (c0 - c2) / (2.0 * slope))
