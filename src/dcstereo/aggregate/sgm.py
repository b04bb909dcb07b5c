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

from dcstereo._vector.sgm import path_step, path_total_step, paths_step
from dcstereo.result import FLAG_BORDER, FLAG_MISMATCH, FLAG_OCCLUDED

#: Pad of the path buffers at ``k = -1`` and ``k = Dp`` (never less than a path value;
#: ``PAD + P1`` saturates at the int16 bound).
PAD = 16383

#: Sub-pixel fits of :func:`final_pass` (``subpixel`` argument).
SUBPIXEL_NONE = 0
SUBPIXEL_PARABOLA = 1
SUBPIXEL_EQUIANGULAR = 2


@nb.njit(cache=True)
def _gradient_p2(luma, y, x, yq, xq, p2_table):
    return p2_table[abs(luma[y, x] - luma[yq, xq])]


@nb.njit(cache=True)
def _path_buffer(slots, lanes):
    """``slots`` path vectors of ``lanes`` values with their pads, and a last one of zeros.

    Slot ``s`` starts at ``s * (lanes + 2)``: ``PAD``, the values, ``PAD``. The last slot
    holds zeros: the predecessor of a path's first pixel (``L = C`` from it).
    """
    stride = lanes + 2
    buffer = np.empty((slots + 1) * stride, dtype=np.int16)
    for s in range(slots + 1):
        buffer[s * stride] = PAD
        buffer[s * stride + lanes + 1] = PAD
    zero = slots * stride
    for k in range(lanes):
        buffer[zero + 1 + k] = 0
    return buffer


@nb.njit(cache=True)
def vertical_pass(cost, luma, y_first, y_last, step, p1, p2_table, diagonals, sums):
    """Aggregate the paths from above (``step`` 1) or below (-1), rows ``y_first..y_last``.

    ``cost`` and ``sums`` are ``(H, W, Dp)`` int16 volumes of a strip of rows, flattened
    (C order), and ``luma`` (int32, ``(H, W)``) the strip's intensity; row ``y_first``
    starts every path. ``sums[y, x]`` receives the sum of the vertical path's value and,
    with ``diagonals``, of the two diagonal paths' (predecessors ``x - 1`` and ``x + 1`` in
    the previous row; a diagonal path whose predecessor is beyond the image starts at the
    pixel). The paths of a pixel are one :func:`~.sgm_simd.paths_step`.
    """
    height, width = luma.shape
    lanes = cost.size // (height * width)
    npaths = 3 if diagonals else 1
    stride = lanes + 2
    slots = width + 2  # slot x + 1 holds pixel x; slots 0 and width + 1 lie beyond the image
    prev = _path_buffer(npaths * slots, lanes)
    cur = _path_buffer(npaths * slots, lanes)
    zero = npaths * slots * stride  # the slot of zeros
    prev_min = np.zeros((npaths, slots), dtype=np.int64)
    cur_min = np.zeros((npaths, slots), dtype=np.int64)
    mins = np.zeros(3, dtype=np.int64)
    y = y_first
    first = True
    while True:
        row = y * width * lanes
        yq = y - step
        for x in range(width):
            c_off = row + x * lanes
            q0 = (x + 1) * stride
            if first:
                p0, p2_0, mins[0] = zero, 0, 0
            else:
                p0, p2_0, mins[0] = (
                    q0,
                    _gradient_p2(luma, y, x, yq, x, p2_table),
                    prev_min[0, x + 1],
                )
            if diagonals:
                q1 = (slots + x + 1) * stride
                q2 = (2 * slots + x + 1) * stride
                if first or x == 0:
                    p1_, p2_1, mins[1] = zero, 0, 0
                else:
                    p1_ = (slots + x) * stride
                    p2_1 = _gradient_p2(luma, y, x, yq, x - 1, p2_table)
                    mins[1] = prev_min[1, x]
                if first or x == width - 1:
                    p2_, p2_2, mins[2] = zero, 0, 0
                else:
                    p2_ = (2 * slots + x + 2) * stride
                    p2_2 = _gradient_p2(luma, y, x, yq, x + 1, p2_table)
                    mins[2] = prev_min[2, x + 2]
                paths_step(
                    cost, c_off, prev, (p0, p1_, p2_), cur, (q0, q1, q2), lanes, p1,
                    (p2_0, p2_1, p2_2), mins, sums, c_off,
                )  # fmt: skip
                cur_min[1, x + 1] = mins[1]
                cur_min[2, x + 1] = mins[2]
            else:
                paths_step(
                    cost, c_off, prev, (p0,), cur, (q0,), lanes, p1, (p2_0,), mins, sums, c_off
                )
            cur_min[0, x + 1] = mins[0]
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

    ``confidence`` (float32, the shape of ``disparity``, or of no columns: not wanted) receives
    ``(rival - best) / rival`` of each pixel's totals, ``rival`` the least total of the
    disparities two or more away from the chosen one (NaN where there is none or it is 0).
    """
    height, width = luma.shape
    lanes = cost.size // (height * width)
    rows = y1 - y0
    for i in nb.prange((rows + 1) // 2):  # two rows at a time: two chains of dependent steps
        ra = 2 * i
        pair = ra + 1 < rows
        rb = ra + 1 if pair else ra
        hbuf_a, hbuf_b = _path_buffer(width, lanes), _path_buffer(width, lanes)
        back_a, back_b = _path_buffer(2, lanes), _path_buffer(2, lanes)
        total_a = np.empty(width * lanes, dtype=np.int16)
        total_b = np.empty(width * lanes, dtype=np.int16)
        best_a = np.empty(width, dtype=np.int64)
        best_b = np.empty(width, dtype=np.int64)
        _horizontal_rows(
            cost, luma, down, up, y0 + ra, y0 + rb, pair, lanes, p1, p2_table,
            hbuf_a, hbuf_b, back_a, back_b, total_a, total_b, best_a, best_b, ndisp,
        )  # fmt: skip
        _choose_row(
            total_a, best_a, lanes, width, dmin, ndisp, subpixel, tolerance, disparity[ra],
            flags[ra], confidence[ra],
        )  # fmt: skip
        if pair:
            _choose_row(
                total_b, best_b, lanes, width, dmin, ndisp, subpixel, tolerance, disparity[rb],
                flags[rb], confidence[rb],
            )  # fmt: skip


@nb.njit(cache=True)
def _horizontal_rows(
    cost, luma, down, up, ya, yb, pair, lanes, p1, p2_table, hbuf_a, hbuf_b, back_a, back_b,
    total_a, total_b, best_a, best_b, ndisp,
):  # fmt: skip
    """Run the two horizontal paths of rows ``ya`` and ``yb``, and their pixels' totals.

    ``yb`` only with ``pair``. ``best_a``/``best_b`` receive each pixel's first least total.
    The steps of the two rows are interleaved, so that the processor runs one row's while
    the other's wait on their predecessor's least value.
    """
    width = luma.shape[1]
    stride = lanes + 2
    row_a, row_b = ya * width * lanes, yb * width * lanes
    zero = width * stride  # the slot of zeros: the predecessor of a path's first pixel
    ha = path_step(cost, row_a, hbuf_a, zero, hbuf_a, 0, lanes, p1, 0, 0)
    hb = path_step(cost, row_b, hbuf_b, zero, hbuf_b, 0, lanes, p1, 0, 0) if pair else 0
    for x in range(1, width):  # left to right
        prev, here = (x - 1) * stride, x * stride
        p2 = _gradient_p2(luma, ya, x, ya, x - 1, p2_table)
        ha = path_step(cost, row_a + x * lanes, hbuf_a, prev, hbuf_a, here, lanes, p1, p2, ha)
        if pair:
            p2 = _gradient_p2(luma, yb, x, yb, x - 1, p2_table)
            hb = path_step(cost, row_b + x * lanes, hbuf_b, prev, hbuf_b, here, lanes, p1, p2, hb)
    parts_a, parts_b = (down, up, hbuf_a), (down, up, hbuf_b)
    ma = mb = 0
    for x in range(width - 1, -1, -1):  # right to left, the totals and their least
        q = (x % 2) * stride
        if x == width - 1:
            p_off, p2a, p2b = 2 * stride, 0, 0
        else:
            p_off = ((x + 1) % 2) * stride
            p2a = _gradient_p2(luma, ya, x, ya, x + 1, p2_table)
            p2b = _gradient_p2(luma, yb, x, yb, x + 1, p2_table)
        offs = x * lanes
        c_off = row_a + offs
        ma, k, _ = path_total_step(
            cost, c_off, back_a, p_off, back_a, q, lanes, p1, p2a, ma, parts_a,
            (c_off, c_off, x * stride + 1), total_a, offs,
        )  # fmt: skip
        best_a[x] = min(k, ndisp - 1)
        if pair:
            c_off = row_b + offs
            mb, k, _ = path_total_step(
                cost, c_off, back_b, p_off, back_b, q, lanes, p1, p2b, mb, parts_b,
                (c_off, c_off, x * stride + 1), total_b, offs,
            )  # fmt: skip
            best_b[x] = min(k, ndisp - 1)


@nb.njit(cache=True)
def _choose_row(total, best_k, lanes, width, dmin, ndisp, subpixel, tolerance, disparity,
                flags, confidence):  # fmt: skip
    """Winner-take-all, left-right check and sub-pixel fit of one row (see ``final_pass``)."""
    right_best = np.full(width, 1 << 30, dtype=np.int64)
    right_d = np.full(width, -(1 << 30), dtype=np.int64)
    for x in range(width):  # the right view keeps the best of the left pixels choosing it
        k = best_k[x]
        value = total[x * lanes + k]
        if confidence.size:
            confidence[x] = _margin(total, x * lanes, k, ndisp, value)
        xr = x - dmin - k
        if 0 <= xr < width and value < right_best[xr]:
            right_best[xr] = value
            right_d[xr] = dmin + k
    for x in range(width):
        k = best_k[x]
        d = dmin + k
        xr = x - d
        if xr < 0 or xr >= width:
            disparity[x] = np.nan
            flags[x] = FLAG_BORDER
        elif tolerance >= 0 and abs(right_d[xr] - d) > tolerance:
            disparity[x] = np.nan
            flags[x] = FLAG_OCCLUDED if right_d[xr] > d else FLAG_MISMATCH
        else:
            offset = _subpixel(total, x * lanes, k, ndisp, subpixel)  # |offset| < 0.5
            disparity[x] = np.float32(d + offset)
            flags[x] = 0
