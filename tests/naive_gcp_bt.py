"""Slow, obviously correct twins of the Birchfield-Tomasi and ground-control-point kernels.

They follow the written definitions (``costs.row_costs_bt`` and ``gcp.select_gcps``)
in plain Python with fractions of a gray level as floats, and share no index arithmetic
with the kernels: the BT twin interpolates half pixels explicitly, and the GCP twin tries
every subset of the candidates.
"""

import itertools
import math

import numpy as np


def sample(row, position):
    """Linear interpolation of a row at ``position`` (a multiple of 1/2), edge-clamped.

    A half-pixel position next to the image edge has only one neighbour inside; the
    missing one is replaced by the pixel itself, so the value is the pixel's.
    """
    width = len(row)
    lo = math.floor(position)
    hi = math.ceil(position)
    lo = min(max(lo, 0), width - 1)
    hi = min(max(hi, 0), width - 1)
    return (float(row[lo]) + float(row[hi])) / 2.0


def bt_pixel(left_row, right_row, x_left, x_right):
    """Birchfield-Tomasi dissimilarity of one pixel pair, in the units of the rows."""
    value_left = float(left_row[x_left])
    value_right = float(right_row[x_right])
    around_right = [sample(right_row, x_right + h) for h in (-0.5, 0.0, 0.5)]
    around_left = [sample(left_row, x_left + h) for h in (-0.5, 0.0, 0.5)]
    d_lr = max(0.0, value_left - max(around_right), min(around_right) - value_left)
    d_rl = max(0.0, value_right - max(around_left), min(around_left) - value_right)
    return min(d_lr, d_rl)


def window_bt(left_signal, right_signal, y, x_left, x_right, radius):
    """Windowed BT of one DSI cell, truncated and rescaled like ``naive.window_sad``."""
    height, width = left_signal.shape
    total = 0.0
    used = 0
    for s in range(-radius, radius + 1):
        xl, xr = x_left + s, x_right + s
        if not (0 <= xl < width and 0 <= xr < width):
            continue
        used += 1
        for t in range(-radius, radius + 1):
            yy = min(max(y + t, 0), height - 1)
            total += bt_pixel(left_signal[yy], right_signal[yy], xl, xr)
    win = 2 * radius + 1
    return total if used == win else total * 2 * win / used / 2


def row_costs_bt(left_signal, right_signal, y, dmin, ndisp, radius):
    """Banded BT DSI of row ``y``: ``out[x, k]`` for ``d = dmin + k``, inf outside."""
    width = left_signal.shape[1]
    out = np.full((width, ndisp), np.inf)
    for x in range(width):
        for k in range(ndisp):
            j = x - (dmin + k)
            if 0 <= j < width:
                out[x, k] = window_bt(left_signal, right_signal, y, x, j, radius)
    return out


def ratio_test(costs, best):
    """Second-least cost (at least two disparities away) over the cost at ``best``."""
    others = [c for k, c in enumerate(costs) if abs(k - best) > 1]
    second = min(others) if others else math.inf
    if costs[best] > 0:
        return second / costs[best]
    return math.inf if second > 0 else 1.0


def gcp_candidates(cost, var_l, dmin, radius, uniqueness, var_floor):
    """Every left pixel that passes the four tests, as ``(x_left, x_right)`` in x order."""
    width, ndisp = cost.shape
    found = []
    for x in range(width):
        if not (radius <= x < width - radius) or not var_l[x] >= var_floor:
            continue
        costs = list(cost[x])
        if not any(c < math.inf for c in costs):
            continue
        best = costs.index(min(costs))  # the first of equal costs
        j = x - dmin - best
        if not radius <= j < width - radius:
            continue
        if ratio_test(costs, best) < uniqueness:
            continue
        # every left pixel that could match right pixel j, with its cost
        rivals = [
            cost[x2, x2 - j - dmin] for x2 in range(width) if x2 != x and 0 <= x2 - j - dmin < ndisp
        ]
        if any(c <= costs[best] for c in rivals):
            continue
        found.append((x, j))
    return found


def select_gcps(cost, var_l, dmin, radius, uniqueness, var_floor):
    """The kept points: the longest subset increasing in both coordinates, by brute force.

    Among the subsets of that size, the first one ``itertools.combinations`` yields
    (lexicographic in the candidates' indices). Returns ``(kept, candidates)``.
    """
    found = gcp_candidates(cost, var_l, dmin, radius, uniqueness, var_floor)
    for size in range(len(found), 0, -1):
        for subset in itertools.combinations(found, size):
            if all(
                a[0] < b[0] and a[1] < b[1] for a, b in zip(subset[:-1], subset[1:], strict=True)
            ):
                return list(subset), found
    return [], found
