"""The kernels of the depth-edge re-decision (:mod:`dcstereo.refine.edges`).

A pixel whose window of the map spans a jump considers the values just past the jumps it
can reach along five directions, and takes the one whose colour-weighted matching cost
over a window (adaptive support weights, the weights from both views) is lower than its
own value's by a margin.
"""

import numba as nb
import numpy as np

from dcstereo._vector.sgm import next_task
from dcstereo.costs.census import popcount

#: The directions a pixel looks along for another surface, ``(dy, dx)``: all but those to
#: its left, where the pixels near a depth edge are the occluded ones.
DIRECTIONS = np.array([(-1, 0), (-1, 1), (0, 1), (1, 0), (1, 1)], dtype=np.int64)

#: A step along a direction of more than this (pixels of disparity) between two
#: neighbours is a jump: :func:`edge_candidates` stops there, :func:`reachable_jumps`
#: looks for one.
RAY_STEP = 1.0


#: The largest argument of :func:`exp_minus` it is accurate for.
EXP_DOMAIN = 2.5
#: The largest argument of :func:`exp_minus_wide` it is accurate for: two differences of
#: 255 over a scale of 10.
WIDE_DOMAIN = 51.2
#: :func:`exp_minus`'s largest relative error over its domain (measured: 6.1e-7; float32's
#: rounding is 6e-8, the two squarings multiply it by four).
EXP_ERROR = 1e-6
#: :func:`exp_minus_wide`'s largest relative error over its domain (measured: 1.2e-5).
WIDE_ERROR = 2e-5
#: :func:`support_cost`'s largest relative difference from the float64 definition
#: (measured: 8.2e-7 over 800 windows of the tests' scene, float32 sums of 225 terms).
COST_ERROR = 2e-6


@nb.njit(cache=True, inline="always")
def exp_series(s):
    """Return ``exp(s)`` in float32 by its Taylor series to the 10th power (Horner), small ``s``.

    ``s`` a float32, ``-0.8 <= s <= 0``: the first term left out is under 2.2e-9 of the
    sum, below float32's own rounding. Arithmetic only, which the compiler makes vector
    code of (a call of the maths library's ``exp`` stays one value at a time, and took 40 %
    of the edge stage), eight values a vector on AVX2. Written out: as a loop over a table
    of the coefficients the support cost took 2.3x the time (the compiler no longer made
    vector code of the loop around it).
    """
    p = np.float32(1 / 3628800)
    p = np.float32(1 / 362880) + s * p
    p = np.float32(1 / 40320) + s * p
    p = np.float32(1 / 5040) + s * p
    p = np.float32(1 / 720) + s * p
    p = np.float32(1 / 120) + s * p
    p = np.float32(1 / 24) + s * p
    p = np.float32(1 / 6) + s * p
    p = np.float32(1 / 2) + s * p
    p = np.float32(1.0) + s * p
    return np.float32(1.0) + s * p


@nb.njit(cache=True, inline="always")
def exp_minus(t):
    """Return ``exp(-t)`` in float32 for ``0 <= t <=`` :data:`EXP_DOMAIN` (``t`` a float32).

    :func:`exp_series` of ``-t / 4``, squared twice: the support cost's two terms. Relative
    error under :data:`EXP_ERROR`.
    """
    p = exp_series(np.float32(-0.25) * t)
    p = p * p
    return p * p


@nb.njit(cache=True, inline="always")
def exp_minus_wide(t):
    """Return ``exp(-t)`` in float32 for ``0 <= t <=`` :data:`WIDE_DOMAIN` (``t`` a float32).

    :func:`exp_series` of ``-t / 64``, squared six times: the support weights' colour
    factor, of both views' differences at once. The squarings multiply the series'
    rounding by 64: relative error under :data:`WIDE_ERROR`, which a weight does not feel.
    """
    p = exp_series(t * np.float32(-1 / 64))
    for _ in range(6):
        p = p * p
    return p


#: The columns of a window row that :func:`support_cost` takes at a time (vector code of a
#: constant count; its views padded past the image so that every block reads inside them).
LANES = 16

#: The lanes' places in a block, as floats: the test of a column inside the window is then
#: float32 vector code too (a 64-bit index would halve the vectors' lanes).
LANE_PLACES = np.arange(LANES, dtype=np.float32)


@nb.njit(cache=True, fastmath={"reassoc", "nsz", "contract"})
def support_cost(left, right, codes_l, codes_r, pad, y, x, d, radius, weight_scale, space_weight,
                 truncation, census_scale, colour_scale):  # fmt: skip
    """Return the adaptive-support-weight cost of disparity ``d`` at left pixel ``(y, x)``.

    Over the ``(2 radius + 1)^2`` window inside the image, each left pixel ``q`` against
    the right view at ``q - d`` (linearly interpolated along the row; a ``q`` whose match
    leaves the view does not count): its cost ``2 - exp(-h / census_scale) - exp(-c /
    colour_scale)``, ``h`` the interpolated Hamming distance of the census codes and ``c``
    the channels' summed absolute difference, truncated at ``truncation``, over 3; its
    weight ``exp(-(g_l + g_r) / weight_scale) * space_weight[dy, dx]``, ``g_l`` the
    largest channel difference of ``q`` from the centre in the left view and ``g_r`` that
    of their matches in the right view (rounded): the product of the two views' colour
    weights. The weighted mean; ``inf`` when nothing counts (the centre's match outside
    the view).

    The views and the codes are those of :func:`dcstereo.refine.edges.padded_views`:
    ``pad`` columns on the left of the image's, and ``pad + LANES`` on its right
    (``pad >= radius + 2``); ``space_weight`` has its rows padded with zeros to a multiple
    of :data:`LANES` columns (float32). Vector code in float32, eight lanes a vector on
    AVX2, :data:`LANES` columns of a window row at a time (those outside the window or the
    views weigh 0): the exponentials by :func:`exp_minus` (``h / census_scale`` and ``c /
    3 / colour_scale`` at most :data:`EXP_DOMAIN`) and :func:`exp_minus_wide` (``(g_l +
    g_r) / weight_scale`` at most :data:`WIDE_DOMAIN`), the sums in any order
    (``fastmath`` reassociation). Against the plain float64 sums with the library's
    ``exp`` (``tests/naive_edges.py``): a relative difference under :data:`COST_ERROR`.
    In float64 (four lanes a vector) the stage took 2x the time, for the same maps on the
    development scenes.
    """
    _, height, padded = left.shape
    width = padded - 2 * pad - LANES  # the image's columns
    xc = x - d
    j0 = int(np.floor(xc))
    if j0 < 0 or xc > width - 1:
        return np.inf
    g = xc - j0
    k = j0 - x  # a sample at column xx matches between columns xx + k and xx + k + 1
    step = 1 if g > 0 else 0  # the second column of the interpolation (weight g)
    j1 = j0 + step
    fp, fq = np.float32(1 - g), np.float32(g)  # the interpolation's weights, in float32
    centre = (
        fp * right[0, y, pad + j0] + fq * right[0, y, pad + j1],
        fp * right[1, y, pad + j0] + fq * right[1, y, pad + j1],
        fp * right[2, y, pad + j0] + fq * right[2, y, pad + j1],
    )
    c0, c1, c2 = (
        np.float32(left[0, y, pad + x]),
        np.float32(left[1, y, pad + x]),
        np.float32(left[2, y, pad + x]),
    )
    # the window's columns inside the image whose match lies inside the right view
    lo = max(x - radius, 0, -k)
    hi = min(x + radius, width - 1, width - 1 - k - step)
    span = np.float32(hi - lo)  # negative: none
    total = np.float32(0.0)
    weights = np.float32(0.0)
    hc = np.float32(1.0 / census_scale)
    cc = np.float32(1.0 / (3 * colour_scale))
    wc = np.float32(1.0 / weight_scale)
    cut = np.float32(truncation)
    first = x - radius  # the window's first column
    for dy in range(-radius, radius + 1):
        yy = y + dy
        if yy < 0 or yy >= height:
            continue
        for block in range(0, 2 * radius + 1, LANES):  # a block of the row as slices: vectors
            f0 = first + block
            l0, l1, l2 = left[0, yy, pad + f0 :], left[1, yy, pad + f0 :], left[2, yy, pad + f0 :]
            p0, p1, p2 = (
                right[0, yy, pad + f0 + k :],
                right[1, yy, pad + f0 + k :],
                right[2, yy, pad + f0 + k :],
            )
            q0, q1, q2 = (
                right[0, yy, pad + f0 + k + step :],
                right[1, yy, pad + f0 + k + step :],
                right[2, yy, pad + f0 + k + step :],
            )
            cl = codes_l[yy, pad + f0 :]
            cp, cq = codes_r[yy, pad + f0 + k :], codes_r[yy, pad + f0 + k + step :]
            sw = space_weight[dy + radius, block:]
            start = np.float32(f0 - lo)  # the block's first column, from lo
            for i in range(LANES):
                r0 = fp * p0[i] + fq * q0[i]
                r1 = fp * p1[i] + fq * q1[i]
                r2 = fp * p2[i] + fq * q2[i]
                a0, a1, a2 = np.float32(l0[i]), np.float32(l1[i]), np.float32(l2[i])
                gl = max(abs(a0 - c0), abs(a1 - c1), abs(a2 - c2))  # whole levels: exact
                e0, e1, e2 = abs(r0 - centre[0]), abs(r1 - centre[1]), abs(r2 - centre[2])
                e01 = e0 if e0 > e1 else e1
                g_right = e01 if e01 > e2 else e2
                colour = abs(a0 - r0) + abs(a1 - r1) + abs(a2 - r2)
                colour = colour if colour < cut else cut
                code = cl[i]
                bits_p = np.float32(np.int32(popcount(code ^ cp[i])))
                bits_q = np.float32(np.int32(popcount(code ^ cq[i])))
                hamming = fp * bits_p + fq * bits_q
                cost = np.float32(2.0) - exp_minus(hamming * hc) - exp_minus(colour * cc)
                gr = np.floor(g_right + np.float32(0.5))  # at most 255: the levels are 0..255
                column = start + LANE_PLACES[i]
                inside = (column >= 0) & (column <= span)
                weight = exp_minus_wide((gl + gr) * wc) * sw[i] if inside else np.float32(0.0)
                total += weight * cost
                weights += weight
    if weights <= 0:
        return np.inf
    return np.float64(total) / np.float64(weights)


@nb.njit(cache=True)
def edge_candidates(disparity, left, flags, y, x, reach, colour_limit, out):
    """Write into ``out`` the values past the jumps pixel ``(y, x)`` may take; return how many.

    Along each of :data:`DIRECTIONS`, up to ``reach`` pixels: the walk stops at the image's
    edge, at a pixel whose left colour differs from the centre's by more than
    ``colour_limit`` in a channel, or at the first jump (a step of more than
    :data:`RAY_STEP` from the pixel before it). A jump's value is a candidate when it is
    farther (smaller) than the pixel's own, its pixel carries no flag (an estimate of the
    matcher's own), and it lies 0.5 or more from every candidate before it.
    """
    height, width = disparity.shape
    own = disparity[y, x]
    count = 0
    for k in range(DIRECTIONS.shape[0]):
        sy, sx = DIRECTIONS[k, 0], DIRECTIONS[k, 1]
        for r in range(1, reach + 1):
            yy, xx = y + sy * r, x + sx * r
            if yy < 0 or yy >= height or xx < 0 or xx >= width:
                break
            step = 0
            for c in range(3):
                step = max(step, abs(left[c, yy, xx] - left[c, y, x]))
            if step > colour_limit:
                break
            value = disparity[yy, xx]
            if not abs(value - disparity[yy - sy, xx - sx]) > RAY_STEP:
                continue  # no jump (or no estimate: NaN): walk on
            if value < own and flags[yy, xx] == 0:
                new = True
                for j in range(count):
                    if abs(out[j] - value) < 0.5:
                        new = False
                if new:
                    out[count] = value
                    count += 1
            break
    return count


@nb.njit(cache=True, parallel=True)
def row_extremes(disparity, zone, low, high):
    """Write the least and the largest value of each pixel's ``2 zone + 1`` columns.

    The row's edges repeated; NaN (no estimate) is neither, and a pixel whose columns hold
    none gets ``+inf`` and ``-inf``. The window of :func:`edge_rows` then takes its rows'
    extremes: 14 reads a pixel instead of 49, the same values.
    """
    height, width = disparity.shape
    for y in nb.prange(height):
        for x in range(width):
            lo, hi = np.inf, -np.inf
            for dx in range(-zone, zone + 1):
                v = disparity[y, min(max(x + dx, 0), width - 1)]
                if v < lo:  # NaN: neither
                    lo = v
                if v > hi:
                    hi = v
            low[y, x] = lo
            high[y, x] = hi


@nb.njit(cache=True, parallel=True)
def reachable_jumps(disparity, reach, out):
    """Mark each pixel that :func:`edge_candidates` could give a candidate (a test it passes).

    ``out[y, x]``: some pixel ``q`` at ``1..reach`` steps along one of :data:`DIRECTIONS`,
    inside the image, differs by more than :data:`RAY_STEP` from the pixel one step before
    it and holds a value below ``disparity[y, x]``. A candidate is such a pixel (the walk
    stops there), so a pixel left unmarked has none, and :func:`edge_rows` skips it: on
    KITTI 000066 two thirds of the pixels whose window spans a jump. Each step of each
    direction is one pass over the row's columns (vector code, NaN on either side: no
    jump).
    """
    height, width = disparity.shape
    for y in nb.prange(height):
        mark = out[y]
        mark[:] = False
        own = disparity[y]
        for k in range(DIRECTIONS.shape[0]):
            sy, sx = DIRECTIONS[k, 0], DIRECTIONS[k, 1]
            for r in range(1, reach + 1):
                yy = y + sy * r
                if yy < 0 or yy >= height:
                    break
                last = width - sx * r  # the columns whose step stays inside the image
                if last <= 0:
                    break
                here = disparity[yy, sx * r :]
                before = disparity[yy - sy, sx * (r - 1) :]
                for x in range(last):
                    value = here[x]
                    mark[x] |= (abs(value - before[x]) > RAY_STEP) & (value < own[x])


@nb.njit(cache=True, parallel=True)
def edge_rows(disparity, flags, left, left_p, right_p, codes_l_p, codes_r_p, pad, row_low,
              row_high, reachable, zone, jump, reach, colour_limit, radius, weight_scale,
              space_weight, truncation, census_scale, colour_scale, margin, out,
              threads=1):  # fmt: skip
    """Write into ``out`` the re-decided map (rows in parallel).

    A pixel with an estimate whose ``(2 zone + 1)^2`` window (the edges repeated; the
    estimates alone) spans more than ``jump`` takes the candidate of
    :func:`edge_candidates` of least :func:`support_cost` when that is below ``1 -
    margin`` times its own value's (any finite one, where its own value's match leaves the
    right view); every other pixel keeps its value. ``left``: the left view's channels
    (the candidates' colour walk); ``left_p``, ``right_p``, ``codes_l_p``, ``codes_r_p``,
    ``pad`` and ``space_weight``: the padded views and weights of :func:`support_cost`.
    ``row_low``, ``row_high``: :func:`row_extremes` of ``disparity`` and ``zone``;
    ``reachable``: :func:`reachable_jumps` of ``disparity`` and ``reach`` (the pixels it
    leaves unmarked have no candidate, and keep their value without the walk).

    ``threads``: numba's thread count; the rows are handed out one at a time to whichever
    thread is free (the pixels near a depth edge, which cost the most, gather in some parts
    of an image: on teddy, in two fixed halves of the rows, two threads took 6.0 ms against
    one's 7.9; handed out, 3.8).
    """
    height, width = disparity.shape
    counter = np.zeros(1, dtype=np.int64)
    for _ in nb.prange(max(1, min(threads, height))):
        candidates = np.empty(DIRECTIONS.shape[0], dtype=np.float32)
        y = next_task(counter)
        while y < height:
            _edge_row(disparity, flags, left, left_p, right_p, codes_l_p, codes_r_p, pad,
                      row_low, row_high, reachable, zone, jump, reach, colour_limit, radius,
                      weight_scale, space_weight, truncation, census_scale, colour_scale,
                      margin, out, y, candidates)  # fmt: skip
            y = next_task(counter)


@nb.njit(cache=True)
def _edge_row(disparity, flags, left, left_p, right_p, codes_l_p, codes_r_p, pad, row_low,
              row_high, reachable, zone, jump, reach, colour_limit, radius, weight_scale,
              space_weight, truncation, census_scale, colour_scale, margin, out, y,
              candidates):  # fmt: skip
    """Row ``y`` of :func:`edge_rows`, with the candidates' scratch given."""
    height, width = disparity.shape
    for x in range(width):
        own = disparity[y, x]
        out[y, x] = own
        if not reachable[y, x]:  # no candidate (nor an estimate: NaN is never marked)
            continue
        low, high = own, own
        for dy in range(-zone, zone + 1):  # the rows' extremes: the window's
            yy = min(max(y + dy, 0), height - 1)
            if row_low[yy, x] < low:
                low = row_low[yy, x]
            if row_high[yy, x] > high:
                high = row_high[yy, x]
        if not high - low > jump:
            continue
        count = edge_candidates(disparity, left, flags, y, x, reach, colour_limit, candidates)
        if count == 0:
            continue
        best = support_cost(left_p, right_p, codes_l_p, codes_r_p, pad, y, x, own, radius,
                            weight_scale, space_weight, truncation, census_scale,
                            colour_scale)  # fmt: skip
        bound = best * (1.0 - margin)
        for j in range(count):
            cost = support_cost(left_p, right_p, codes_l_p, codes_r_p, pad, y, x, candidates[j],
                                radius, weight_scale, space_weight, truncation,
                                census_scale, colour_scale)  # fmt: skip
            if cost < bound and cost < best:
                best = cost
                out[y, x] = candidates[j]
