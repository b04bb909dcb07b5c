"""Slow, obviously correct twin of the colour-weighted median (``refine.weighted_median``).

Each window's finite values with their weights as a list, sorted by value, and the first
value whose running weight reaches half the total; the weights from the definition, with
``math.exp`` and ``math.hypot``.
"""

import math

import numpy as np

UNIT = 1024


def weights(radius, colour_scale, space_scale):
    colour = [round(UNIT * math.exp(-g / colour_scale)) for g in range(256)]
    side = 2 * radius + 1
    space = [[round(UNIT * math.exp(-math.hypot(i - radius, j - radius) / space_scale))
              for j in range(side)] for i in range(side)]  # fmt: skip
    return colour, space


def weighted_median_rows(disparity, guide, moved, radius, colour_scale, space_scale,
                         tables=None):  # fmt: skip
    """The map with each moved pixel's weighted median; ``tables``: ``(colour, space)`` in
    place of :func:`weights`' (for weights that the kernel must sum in 64 bits)."""
    colour, space = weights(radius, colour_scale, space_scale) if tables is None else tables
    height, width = disparity.shape
    out = disparity.copy()
    for y in range(height):
        for x in range(width):
            if not moved[y, x]:
                continue
            samples = []
            for yy in range(max(0, y - radius), min(height, y + radius + 1)):
                for xx in range(max(0, x - radius), min(width, x + radius + 1)):
                    v = disparity[yy, xx]
                    if not np.isfinite(v):  # NaN or infinite: no estimate
                        continue
                    g = max(abs(int(guide[c, yy, xx]) - int(guide[c, y, x]))
                            for c in range(guide.shape[0]))  # fmt: skip
                    w = colour[g] * space[yy - y + radius][xx - x + radius]
                    samples.append((float(v) + 0.0, w))  # -0.0 as +0.0
            samples.sort()
            total = sum(w for _, w in samples)
            running = 0
            for v, w in samples:
                running += w
                if 2 * running >= total:
                    out[y, x] = v
                    break
    return out
