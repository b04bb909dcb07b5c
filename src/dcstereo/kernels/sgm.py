"""Semi-global aggregation of a cost volume, and the winner-take-all of its sums.

Hirschmueller, *Stereo processing by semiglobal matching and mutual information*, IEEE
TPAMI 30(2), 2008: the cost of each pixel and disparity is aggregated along 1-D paths
that reach it from several directions (eq. 13, :func:`~.sgm_simd.path_step`), and the
sums ``S(p, d)`` of the paths (eq. 14) choose the disparity. Eight paths: left to right,
right to left, and the three from the rows above and the three from the rows below (one
vertical, two diagonal); four paths keep the horizontal and the vertical ones.

The volume is swept three times, each sweep streaming through it once:

* :func:`vertical_pass` down the rows (the paths from above) into one sum volume, and up
  the rows (the paths from below) into another; the two are independent, so they run side
  by side (:func:`vertical_passes`);
* :func:`final_pass`, rows in parallel: the two horizontal paths of the row, the total
  of the four sums, the least total of each pixel (winner-take-all) with its sub-pixel
  fit, and the left-right check against the right view's choices.

Costs and path values are ``int16``; lanes ``k >= ndisp`` of each pixel (the vector
padding) hold a cost no real one reaches, so they never win and never lower a minimum.
The smoothness penalty ``P2`` of a step is read from a table by the absolute difference of
the two pixels' intensities (1/16 gray levels): smaller across edges.
"""

import numba as nb
import numpy as np

from .sgm_simd import add_saturated, first_min, path_start, path_step

#: Pad of the path buffers at ``k = -1`` and ``k = Dp`` (never less than a path value;
#: ``PAD + P1`` saturates at the int16 bound).
PAD = 16383

#: Sub-pixel fits of :func:`final_pass` (``subpixel`` argument).
SUBPIXEL_NONE = 0
SUBPIXEL_PARABOLA = 1
SUBPIXEL_EQUIANGULAR = 2

#: Reason flags (mirrored in ``dcstereo.result``).
FLAG_OCCLUDED = 1
FLAG_BORDER = 2
FLAG_MISMATCH = 16


@nb.njit(cache=True)
def _gradient_p2(luma, y, x, yq, xq, p2_table):
    return p2_table[abs(luma[y, x] - luma[yq, xq])]


@nb.njit(cache=True)
def vertical_pass(cost, luma, y_first, y_last, step, p1, p2_table, diagonals, sums):
    """The paths from above (``step`` 1) or below (-1), rows ``y_first`` to ``y_last``.

    ``cost`` and ``sums`` are ``(H, W, Dp)`` int16 volumes of a strip of rows, flattened
    (C order), and ``luma`` (int32, ``(H, W)``) the strip's intensity; row ``y_first``
    starts every path. ``sums[y, x]`` receives the sum of the vertical path's
    value and, with ``diagonals``, of the two diagonal paths' (predecessors ``x - 1`` and
    ``x + 1`` in the previous row; a diagonal path whose predecessor is beyond the image
    starts at the pixel).
    """
    height, width = luma.shape
    lanes = cost.size // (height * width)
    npaths = 3 if diagonals else 1
    stride = lanes + 2
    slots = width + 2  # slot x + 1 holds pixel x; slots 0 and width + 1 lie beyond the image
    prev = np.empty(npaths * slots * stride, dtype=np.int16)
    cur = np.empty(npaths * slots * stride, dtype=np.int16)
    for s in range(npaths * slots):
        prev[s * stride] = PAD
        prev[s * stride + lanes + 1] = PAD
        cur[s * stride] = PAD
        cur[s * stride + lanes + 1] = PAD
    prev_min = np.empty((npaths, slots), dtype=np.int64)
    cur_min = np.empty((npaths, slots), dtype=np.int64)
    y = y_first
    first = True
    while True:
        row = y * width * lanes
        for x in range(width):
            c_off = row + x * lanes
            for p in range(npaths):
                shift = 0 if p == 0 else (-1 if p == 1 else 1)  # predecessor column offset
                q_off = (p * slots + x + 1) * stride
                xq = x + shift
                if first or xq < 0 or xq >= width:
                    cur_min[p, x + 1] = path_start(cost, c_off, cur, q_off, lanes)
                else:
                    p2 = _gradient_p2(luma, y, x, y - step, xq, p2_table)
                    p_off = (p * slots + xq + 1) * stride
                    cur_min[p, x + 1] = path_step(
                        cost, c_off, prev, p_off, cur, q_off, lanes, p1, p2, prev_min[p, xq + 1]
                    )
            o0 = (x + 1) * stride + 1
            if diagonals:
                o1 = (slots + x + 1) * stride + 1
                o2 = (2 * slots + x + 1) * stride + 1
                add_saturated(sums, c_off, cur, o0, cur, o1, lanes)
                add_saturated(sums, c_off, sums, c_off, cur, o2, lanes)
            else:
                for k in range(lanes):
                    sums[c_off + k] = cur[o0 + k]
        prev, cur = cur, prev
        prev_min, cur_min = cur_min, prev_min
        first = False
        if y == y_last:
            break
        y += step


@nb.njit(cache=True, parallel=True)
def vertical_passes(cost, luma, p1, p2_table, diagonals, down, up):
    """:func:`vertical_pass` down the strip into ``down`` and up it into ``up``, side by side."""
    last = luma.shape[0] - 1
    for task in nb.prange(2):
        if task == 0:
            vertical_pass(cost, luma, 0, last, 1, p1, p2_table, diagonals, down)
        else:
            vertical_pass(cost, luma, last, 0, -1, p1, p2_table, diagonals, up)


@nb.njit(cache=True)
def _subpixel(t, off, k, ndisp, mode):
    """Offset in ``(-0.5, 0.5)`` of the least total ``t[off + k]`` from its neighbours."""
    if mode == SUBPIXEL_NONE or k <= 0 or k >= ndisp - 1:
        return 0.0
    a = np.float64(t[off + k - 1])
    b = np.float64(t[off + k])
    c = np.float64(t[off + k + 1])
    if mode == SUBPIXEL_PARABOLA:
        den = a - 2.0 * b + c
        return (a - c) / (2.0 * den) if den > 0 else 0.0
    den = max(a, c) - b  # equiangular: two lines of opposite slopes through the three
    return (a - c) / (2.0 * den) if den > 0 else 0.0


@nb.njit(cache=True)
def _margin(t, off, k, ndisp, best):
    """``(rival - best) / rival`` for the least total ``rival`` two or more disparities off."""
    rival = 1 << 30
    for j in range(ndisp):
        if abs(j - k) >= 2 and t[off + j] < rival:
            rival = t[off + j]
    if rival == 1 << 30 or rival <= 0:
        return np.float32(np.nan)
    return np.float32((rival - best) / rival)


@nb.njit(cache=True, parallel=True)
def final_pass(
    cost, luma, down, up, y0, y1, dmin, ndisp, p1, p2_table, subpixel, tolerance, disparity, flags,
    confidence,
):  # fmt: skip
    """Horizontal paths, totals, winner-take-all and left-right check of rows ``y0..y1 - 1``.

    Rows of the strip (``luma``'s rows; ``cost``, ``down`` and ``up`` its flattened
    ``(H, W, Dp)`` volumes); the results of strip row ``y`` go to row ``y - y0`` of
    ``disparity`` and ``flags``. The total of a pixel is the sum of the four path sums (saturated).
    The left-right check follows OpenCV's SGBM: each right pixel keeps the disparity of
    the left pixel of least total that chose it; a left pixel whose disparity differs from
    its right pixel's by more than ``tolerance`` loses its estimate (NaN), flagged
    ``FLAG_OCCLUDED`` where the right pixel's disparity is the larger (it belongs to a
    nearer surface, which hides this pixel from the right view) and ``FLAG_MISMATCH``
    otherwise; a choice whose right pixel lies beyond the image is ``FLAG_BORDER``.

    ``confidence`` (float32, the shape of ``disparity``, or empty: not wanted) receives
    ``(rival - best) / rival`` of each pixel's totals, ``rival`` the least total of the
    disparities two or more away from the chosen one (NaN where there is none or it is 0).
    """
    height, width = luma.shape
    lanes = cost.size // (height * width)
    stride = lanes + 2
    for r in nb.prange(y1 - y0):
        y = y0 + r
        row = y * width * lanes
        hbuf = np.empty(width * stride, dtype=np.int16)
        hmin = np.empty(width, dtype=np.int64)
        back = np.empty(2 * stride, dtype=np.int16)
        total = np.empty(width * lanes, dtype=np.int16)
        best_k = np.empty(width, dtype=np.int64)
        right_best = np.full(width, 1 << 30, dtype=np.int64)
        right_d = np.full(width, -(1 << 30), dtype=np.int64)
        for s in range(width):
            hbuf[s * stride] = PAD
            hbuf[s * stride + lanes + 1] = PAD
        for s in range(2):
            back[s * stride] = PAD
            back[s * stride + lanes + 1] = PAD
        for x in range(width):  # left to right
            if x == 0:
                hmin[x] = path_start(cost, row, hbuf, 0, lanes)
            else:
                p2 = _gradient_p2(luma, y, x, y, x - 1, p2_table)
                hmin[x] = path_step(
                    cost, row + x * lanes, hbuf, (x - 1) * stride, hbuf, x * stride, lanes,
                    p1, p2, hmin[x - 1],
                )  # fmt: skip
        back_min = 0
        for x in range(width - 1, -1, -1):  # right to left, and the totals
            c_off = row + x * lanes
            q = (x % 2) * stride
            if x == width - 1:
                back_min = path_start(cost, c_off, back, q, lanes)
            else:
                p2 = _gradient_p2(luma, y, x, y, x + 1, p2_table)
                back_min = path_step(
                    cost, c_off, back, ((x + 1) % 2) * stride, back, q, lanes, p1, p2, back_min
                )
            t_off = x * lanes
            add_saturated(total, t_off, down, c_off, up, c_off, lanes)
            add_saturated(total, t_off, total, t_off, hbuf, x * stride + 1, lanes)
            add_saturated(total, t_off, total, t_off, back, q + 1, lanes)
        for x in range(width):  # winner-take-all; the right view keeps its best claimant
            k, value = first_min(total, x * lanes, lanes)
            k = min(k, ndisp - 1)
            best_k[x] = k
            if confidence.size:
                confidence[r, x] = _margin(total, x * lanes, k, ndisp, value)
            xr = x - dmin - k
            if 0 <= xr < width and value < right_best[xr]:
                right_best[xr] = value
                right_d[xr] = dmin + k
        for x in range(width):
            k = best_k[x]
            d = dmin + k
            xr = x - d
            if xr < 0 or xr >= width:
                disparity[r, x] = np.nan
                flags[r, x] = FLAG_BORDER
            elif tolerance >= 0 and abs(right_d[xr] - d) > tolerance:
                disparity[r, x] = np.nan
                flags[r, x] = FLAG_OCCLUDED if right_d[xr] > d else FLAG_MISMATCH
            else:
                offset = _subpixel(total, x * lanes, k, ndisp, subpixel)
                disparity[r, x] = np.float32(d + offset)
                flags[r, x] = 0
