"""More global matching: semi-global paths that each follow two predecessors.

Facciolo, de Franchis and Meinhardt, *MGM: a significantly more global matching for
stereovision*, BMVC 2015. Where SGM's path in direction ``r`` reaches pixel ``p`` from
``p - r`` alone, an MGM path averages the messages of two predecessors, ``p - r`` and
``p - r'`` (``r'`` orthogonal to ``r``)::

    m_q(d) = min(L(q, d), L(q, d - 1) + P1, L(q, d + 1) + P1, min L(q) + P2(p, q)) - min L(q)
    L(p, d) = C(p, d) + (m_a(d) + m_b(d)) // 2

so each path carries information from a whole quadrant, not one line, and the streaks of
SGM's 1-D paths fade. A predecessor beyond the image is left out (one predecessor: its
message alone; none: ``L = C``). The paths, all in row order:

* the four quadrants: predecessors ``(x - sx, y)`` and ``(x, y - sy)`` for ``sx, sy = +-1``;
* with ``diagonals``, two more: ``(x - 1, y - sy)`` and ``(x + 1, y - sy)``.

The paths coming from above (``sy = 1``) are summed into one volume and those from below
into another, side by side, as :func:`dcstereo.kernels.sgm.vertical_passes` does, so that
:func:`dcstereo.kernels.sgm.final_pass` can take the two as its ``down`` and ``up`` sums
(with a cost volume of zeros, its horizontal paths add nothing). Values are ``int32``
inside, the sums ``int16``, saturated at ``high``; the lanes ``k >= ndisp`` of the sums
hold ``pad``.
"""

import numba as nb
import numpy as np


@nb.njit(cache=True)
def _message(prev, q, p1, p2, ndisp, low, out, add):
    """Add the message of ``prev[q]`` (its least value ``low``) to ``out``; return nothing."""
    for d in range(ndisp):
        best = prev[q, d]
        if d > 0 and prev[q, d - 1] + p1 < best:
            best = prev[q, d - 1] + p1
        if d < ndisp - 1 and prev[q, d + 1] + p1 < best:
            best = prev[q, d + 1] + p1
        if low + p2 < best:
            best = low + p2
        out[d] = best - low if add == 0 else out[d] + best - low


@nb.njit(cache=True)
def _pass(cost, luma, sy, kind, p1, p2_table, ndisp, high, sums):
    """One path over the strip, rows in the order of ``sy``; its values added to ``sums``.

    ``kind`` 1 or -1: the quadrant path of ``sx = kind``; 0: the diagonal pair.
    """
    height, width = luma.shape
    prev = np.zeros((width, ndisp), dtype=np.int32)
    cur = np.zeros((width, ndisp), dtype=np.int32)
    prev_low = np.zeros(width, dtype=np.int32)
    cur_low = np.zeros(width, dtype=np.int32)
    message = np.empty(ndisp, dtype=np.int32)
    y_first = 0 if sy > 0 else height - 1
    for i in range(height):
        y = y_first + sy * i
        yq = y - sy
        for j in range(width):
            x = j if kind >= 0 else width - 1 - j
            count = 0
            if kind == 0:
                if i > 0 and x > 0:
                    p2 = p2_table[abs(luma[y, x] - luma[yq, x - 1])]
                    _message(prev, x - 1, p1, p2, ndisp, prev_low[x - 1], message, count)
                    count += 1
                if i > 0 and x < width - 1:
                    p2 = p2_table[abs(luma[y, x] - luma[yq, x + 1])]
                    _message(prev, x + 1, p1, p2, ndisp, prev_low[x + 1], message, count)
                    count += 1
            else:
                xq = x - kind
                if j > 0:
                    p2 = p2_table[abs(luma[y, x] - luma[y, xq])]
                    _message(cur, xq, p1, p2, ndisp, cur_low[xq], message, count)
                    count += 1
                if i > 0:
                    p2 = p2_table[abs(luma[y, x] - luma[yq, x])]
                    _message(prev, x, p1, p2, ndisp, prev_low[x], message, count)
                    count += 1
            low = np.int32(1 << 30)
            for d in range(ndisp):
                value = np.int32(cost[y, x, d])
                if count == 1:
                    value += message[d]
                elif count == 2:
                    value += message[d] >> 1
                cur[x, d] = value
                if value < low:
                    low = value
                total = np.int32(sums[y, x, d]) + value
                sums[y, x, d] = min(total, high)
            cur_low[x] = low
        prev, cur = cur, prev
        prev_low, cur_low = cur_low, prev_low


@nb.njit(cache=True, parallel=True)
def mgm_passes(cost, luma, p1, p2_table, diagonals, ndisp, high, pad, down, up):
    """Sum the paths from above into ``down`` and those from below into ``up``, side by side.

    ``cost``, ``down`` and ``up`` are ``(H, W, Dp)`` int16; ``luma`` ``(H, W)`` int32.
    """
    for task in nb.prange(2):
        sums = down if task == 0 else up
        sy = 1 if task == 0 else -1
        height, width, lanes = sums.shape
        for y in range(height):
            for x in range(width):
                for k in range(lanes):
                    sums[y, x, k] = 0 if k < ndisp else pad
        _pass(cost, luma, sy, 1, p1, p2_table, ndisp, high, sums)
        _pass(cost, luma, sy, -1, p1, p2_table, ndisp, high, sums)
        if diagonals:
            _pass(cost, luma, sy, 0, p1, p2_table, ndisp, high, sums)
