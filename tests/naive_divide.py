"""Slow, obviously correct twin of the feature search of ``divide_row`` (section 2).

Plain recursion over the problems ``(A, C, B, D)``: in each, the candidates strictly
inside ``(A, C)`` are tried strongest first (ties: leftmost), every test evaluated afresh
from its definition; the first that passes them all splits the problem. A candidate that
fails a test whose outcome cannot change in a sub-problem is retired for the row (as the
kernel does, which matters only for ``max_candidates``: a retired candidate takes no try).

The window statistics (costs, variances, SSD) come from the compiled primitives, which
have their own tests; this twin checks the search and its tests, not those sums.
"""

import numpy as np


def _uniqueness_ratio(costs, best_k):
    """Second-least cost with ``|k - best_k| > 1`` over the cost at ``best_k``."""
    others = [c for k, c in enumerate(costs) if abs(k - best_k) > 1]
    second = min(others) if others else np.inf
    best = costs[best_k]
    if best > 0:
        return second / best
    return np.inf if second > 0 else 1.0


def _block_match(costs):
    """First index of the least finite cost and its uniqueness ratio; (-1, 0) if none."""
    finite = [k for k, c in enumerate(costs) if np.isfinite(c)]
    if not finite:
        return -1, 0.0
    best_k = min(finite, key=lambda k: (costs[k], k))
    return best_k, _uniqueness_ratio(costs, best_k)


def divide_pairs(
    cost,
    ssd_of,
    var_l,
    var_r,
    *,
    dmin,
    radius,
    ser_min,
    vs_max,
    vs_relative,
    var_floor,
    max_candidates,
    lr_check,
    uniqueness,
    edge_guard,
):
    """Accepted pairs ``{x_left: (x_right, ser, vs)}`` of one row.

    ``cost[x, k]``: the row's window costs, disparity ``dmin + k``; ``ssd_of(p, j)``: the
    window SSD of a pair in gray levels squared; ``var_l``, ``var_r``: window variances.
    """
    width, ndisp = cost.shape
    retired = set()
    pairs = {}

    def guard_ok(p, best_k):
        for x2 in (p - edge_guard, p + edge_guard):
            x2 = min(max(x2, 0), width - 1)
            k2, ratio2 = _block_match(cost[x2])
            if k2 < 0 or abs(k2 - best_k) > 1 or ratio2 < uniqueness:
                return False
        return True

    def solve(a, c, b, e):
        if c - a <= 1 or e - b <= 1:
            return
        order = sorted(
            (p for p in range(max(a + 1, radius), min(c, width - radius)) if var_l[p] >= var_floor),
            key=lambda p: (-var_l[p], p),
        )
        tries = 0
        for p in order:
            if max_candidates > 0 and tries >= max_candidates:
                break
            if p in retired:
                continue
            tries += 1
            # right pixels strictly inside (B, D), their whole window inside the image
            allowed = [
                k
                for k in range(ndisp)
                if max(b + 1, radius) <= p - dmin - k <= min(e - 1, width - 1 - radius)
            ]
            if uniqueness > 0:
                best_k, ratio = _block_match(cost[p])
                if best_k not in allowed or ratio < uniqueness:
                    retired.add(p)
                    continue
            else:
                finite = [k for k in allowed if np.isfinite(cost[p, k])]
                if not finite:
                    continue
                best_k = min(finite, key=lambda k: (cost[p, k], k))
            if edge_guard > 0 and not guard_ok(p, best_k):
                if uniqueness > 0:
                    retired.add(p)
                continue
            j = p - dmin - best_k
            if lr_check:
                rivals = [
                    x
                    for x in range(a + 1, c)
                    if x != p
                    and 0 <= x - j - dmin < ndisp
                    and cost[x, x - j - dmin] <= cost[p, best_k]
                ]
                if rivals:
                    continue
            total = var_l[p] + var_r[j]
            ssd = ssd_of(p, j)
            ser = total / ssd if ssd > 0 else np.inf
            vs = abs(var_l[p] - var_r[j])
            if vs_relative:
                vs = vs / total if total > 0 else 0.0
            if ser >= ser_min and vs <= vs_max:
                retired.add(p)
                pairs[p] = (j, ser, vs)
                solve(a, p, b, j)
                solve(p, c, j, e)
                return
            if uniqueness > 0:
                retired.add(p)

    solve(-1, width, -1, width)
    return pairs


def pixel_variance(signal_p, y, x, radius, signal_steps):
    """Window variance of the one pixel ``(y, x)`` of a padded signal, from exact sums.

    The twin of ``features.window_variance_row`` at one pixel: the same integer sums (here
    Python's) and the same one float64 expression.
    """
    win = 2 * radius + 1
    n = win * win
    values = [int(v) for v in np.asarray(signal_p[y : y + win, x : x + win]).ravel()]
    s = sum(values)
    q = sum(v * v for v in values)
    return float(n * q - s * s) / (float(n) * float(n) * float(signal_steps) * float(signal_steps))


def window_variance(intensity, window):
    """Variance of ``intensity`` over each pixel's ``window x window`` window, edges replicated.

    The numpy twin of the window-variance kernels (``features.window_variance_row``,
    ``band.band_lane_variance``): population variance, ``mean(I^2) - mean(I)^2``.
    """
    array = np.asarray(intensity, dtype=np.float64)
    radius = window // 2
    padded = np.pad(array, radius, mode="edge")

    def box_mean(values):
        c = np.pad(np.cumsum(np.cumsum(values, axis=0), axis=1), ((1, 0), (1, 0)))
        w = window
        return (c[w:, w:] - c[:-w, w:] - c[w:, :-w] + c[:-w, :-w]) / (w * w)

    mean = box_mean(padded)
    return np.maximum(box_mean(padded * padded) - mean * mean, 0.0)
