"""Slow, obviously correct twin of the photometric alignment (``costs.photometric``).

Plain loops over pixels and levels, each definition written out: the box mean, the pairs
of the coarse disparities, a level's quantile and the target level of a quantile.
"""

import math

import numpy as np


def box_down(colour, factor):
    channels, height, width = colour.shape
    rows, cols = height // factor, width // factor
    out = np.zeros((rows, cols, channels), dtype=np.uint8)
    for c in range(channels):
        for y in range(rows):
            for x in range(cols):
                box = [
                    int(colour[c, y * factor + i, x * factor + j])
                    for i in range(factor)
                    for j in range(factor)
                ]
                out[y, x, c] = math.floor(sum(box) / len(box) + 0.5)  # halves up
    return out


def pair_histograms(colour_l, colour_r, coarse, factor):
    channels, height, width = colour_l.shape
    hist_l = np.zeros((channels, 256), dtype=np.int64)
    hist_r = np.zeros((channels, 256), dtype=np.int64)
    pairs = 0
    for y in range(height):
        for x in range(width):
            d = coarse[min(y // factor, coarse.shape[0] - 1), min(x // factor, coarse.shape[1] - 1)]
            if np.isnan(d):
                continue
            xr = round(x - factor * float(d))  # Python rounds halves to even, as np.rint
            if not 0 <= xr < width:
                continue
            pairs += 1
            for c in range(channels):
                hist_l[c, colour_l[c, y, x]] += 1
                hist_r[c, colour_r[c, y, xr]] += 1
    return pairs, hist_l, hist_r


def quantile(hist, level):
    """The share of the counts below ``level`` plus half of its own."""
    total = sum(int(v) for v in hist)
    below = sum(int(v) for v in hist[:level])
    return (below + 0.5 * int(hist[level])) / total


def level_of(hist, q):
    """The level of quantile ``q`` in ``hist``, interpolated between the levels that occur."""
    points = [(quantile(hist, v), v) for v in range(len(hist)) if hist[v] > 0]
    if q <= points[0][0]:
        return float(points[0][1])
    if q >= points[-1][0]:
        return float(points[-1][1])
    for (q0, v0), (q1, v1) in zip(points, points[1:], strict=False):
        if q0 <= q <= q1:
            return v0 + (v1 - v0) * (q - q0) / (q1 - q0)
    raise AssertionError("unreachable")


def quantile_lut(hist_source, hist_target):
    return np.array(
        [round(level_of(hist_target, quantile(hist_source, v))) for v in range(len(hist_source))],
        dtype=np.int16,
    )
