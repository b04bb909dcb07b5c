"""The kernels of the depth-edge re-decision (:mod:`dcstereo.refine.edges`).

A pixel whose window of the map spans a jump considers the values just past the jumps it
can reach along five directions, and takes the one whose colour-weighted matching cost
over a window (adaptive support weights, the weights from both views) is lower than its
own value's by a margin.
"""

import numba as nb
import numpy as np

from dcstereo.costs.census import popcount

#: The directions a pixel looks along for another surface, ``(dy, dx)``: all but those to
#: its left, where the pixels near a depth edge are the occluded ones.
DIRECTIONS = np.array([(-1, 0), (-1, 1), (0, 1), (1, 0), (1, 1)], dtype=np.int64)


@nb.njit(cache=True)
def support_cost(left, right, codes_l, codes_r, y, x, d, radius, colour_weight, space_weight,
                 truncation, census_scale, colour_scale):  # fmt: skip
    """Return the adaptive-support-weight cost of disparity ``d`` at left pixel ``(y, x)``.

    Over the ``(2 radius + 1)^2`` window inside the image, each left pixel ``q`` against
    the right view at ``q - d`` (linearly interpolated along the row; a ``q`` whose match
    leaves the view does not count): its cost ``2 - exp(-h / census_scale) - exp(-c /
    colour_scale)``, ``h`` the interpolated Hamming distance of the census codes and ``c``
    the channels' summed absolute difference, truncated at ``truncation``, over 3; its
    weight ``colour_weight[g_l] * colour_weight[g_r] * space_weight[dy, dx]``, ``g_l`` the
    largest channel difference of ``q`` from the centre in the left view and ``g_r`` that
    of their matches in the right view (rounded). The weighted mean; ``inf`` when nothing
    counts (the centre's match outside the view).
    """
    _, height, width = left.shape
    xc = x - d
    j0 = int(np.floor(xc))
    if j0 < 0 or xc > width - 1:
        return np.inf
    g = xc - j0
    j1 = min(j0 + 1, width - 1)
    centre = (  # the centre's match in the right view, per channel
        (1 - g) * right[0, y, j0] + g * right[0, y, j1],
        (1 - g) * right[1, y, j0] + g * right[1, y, j1],
        (1 - g) * right[2, y, j0] + g * right[2, y, j1],
    )
    total = 0.0
    weights = 0.0
    for dy in range(-radius, radius + 1):
        yy = y + dy
        if yy < 0 or yy >= height:
            continue
        for dx in range(-radius, radius + 1):
            xx = x + dx
            if xx < 0 or xx >= width:
                continue
            xr = xx - d
            if xr < 0 or xr > width - 1:
                continue
            i0 = int(np.floor(xr))
            f = xr - i0
            i1 = min(i0 + 1, width - 1)
            g_left = 0
            g_right = 0.0
            colour = 0.0
            for c in range(3):
                a = left[c, yy, xx]
                g_left = max(g_left, abs(a - left[c, y, x]))
                b = (1 - f) * right[c, yy, i0] + f * right[c, yy, i1]
                g_right = max(g_right, abs(b - centre[c]))
                colour += abs(a - b)
            colour = min(colour, truncation) / 3
            hamming = (1 - f) * popcount(codes_l[yy, xx] ^ codes_r[yy, i0]) + f * popcount(
                codes_l[yy, xx] ^ codes_r[yy, i1]
            )
            cost = 2.0 - np.exp(-hamming / census_scale) - np.exp(-colour / colour_scale)
            weight = (
                colour_weight[g_left]
                * colour_weight[min(int(g_right + 0.5), 255)]
                * space_weight[dy + radius, dx + radius]
            )
            total += weight * cost
            weights += weight
    if weights <= 0:
        return np.inf
    return total / weights


@nb.njit(cache=True)
def edge_candidates(disparity, left, flags, y, x, reach, colour_limit, out):
    """Write into ``out`` the values past the jumps pixel ``(y, x)`` may take; return how many.

    Along each of :data:`DIRECTIONS`, up to ``reach`` pixels: the walk stops at the image's
    edge, at a pixel whose left colour differs from the centre's by more than
    ``colour_limit`` in a channel, or at the first jump (a step of more than 1 from the
    pixel before it). A jump's value is a candidate when it is farther (smaller) than the
    pixel's own, its pixel carries no flag (an estimate of the matcher's own), and it lies
    0.5 or more from every candidate before it.
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
            if not abs(value - disparity[yy - sy, xx - sx]) > 1.0:
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
def edge_rows(disparity, flags, left, right, codes_l, codes_r, zone, jump, reach, colour_limit,
              radius, colour_weight, space_weight, truncation, census_scale, colour_scale,
              margin, out):  # fmt: skip
    """Write into ``out`` the re-decided map (rows in parallel).

    A pixel with an estimate whose ``(2 zone + 1)^2`` window (the edges repeated; the
    estimates alone) spans more than ``jump`` takes the candidate of
    :func:`edge_candidates` of least :func:`support_cost` when that is below ``1 -
    margin`` times its own value's (any finite one, where its own value's match leaves the
    right view); every other pixel keeps its value.
    """
    height, width = disparity.shape
    for y in nb.prange(height):
        candidates = np.empty(DIRECTIONS.shape[0], dtype=np.float32)
        for x in range(width):
            own = disparity[y, x]
            out[y, x] = own
            if not np.isfinite(own):
                continue
            low, high = own, own
            for dy in range(-zone, zone + 1):
                yy = min(max(y + dy, 0), height - 1)
                for dx in range(-zone, zone + 1):
                    v = disparity[yy, min(max(x + dx, 0), width - 1)]
                    if v < low:  # NaN: neither
                        low = v
                    if v > high:
                        high = v
            if not high - low > jump:
                continue
            count = edge_candidates(disparity, left, flags, y, x, reach, colour_limit, candidates)
            if count == 0:
                continue
            best = support_cost(left, right, codes_l, codes_r, y, x, own, radius,
                                colour_weight, space_weight, truncation, census_scale,
                                colour_scale)  # fmt: skip
            bound = best * (1.0 - margin)
            for j in range(count):
                cost = support_cost(left, right, codes_l, codes_r, y, x, candidates[j],
                                    radius, colour_weight, space_weight, truncation,
                                    census_scale, colour_scale)  # fmt: skip
                if cost < bound and cost < best:
                    best = cost
                    out[y, x] = candidates[j]
