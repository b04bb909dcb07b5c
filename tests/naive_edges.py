"""Slow, obviously correct twin of the depth-edge re-decision (``refine.edges``).

Plain Python over lists and ``math``: the census codes as tuples of bits, each window's
cost as a weighted mean written from its definition, the candidates walked pixel by pixel.
"""

import math

import numpy as np

DIRECTIONS = [(-1, 0), (-1, 1), (0, 1), (1, 0), (1, 1)]


def census(intensity, radius):
    height, width = intensity.shape
    codes = {}
    for y in range(height):
        for x in range(width):
            bits = []
            for dy in range(-radius, radius + 1):
                for dx in range(-radius, radius + 1):
                    if dy or dx:
                        yy = min(max(y + dy, 0), height - 1)
                        xx = min(max(x + dx, 0), width - 1)
                        bits.append(intensity[yy, xx] < intensity[y, x])
            codes[y, x] = bits
    return codes


def hamming(a, b):
    return sum(p != q for p, q in zip(a, b, strict=True))


def cost(left, right, codes_l, codes_r, y, x, d, c):
    """The support-weight cost of ``d`` at ``(y, x)``; ``c`` the module's constants."""
    _, height, width = left.shape
    xc = x - d
    if math.floor(xc) < 0 or xc > width - 1:
        return math.inf

    def at(view, row, xr):  # the channels of ``view`` at a fractional column
        i0 = math.floor(xr)
        i1 = min(i0 + 1, width - 1)
        f = xr - i0
        return (
            [(1 - f) * float(view[k, row, i0]) + f * float(view[k, row, i1]) for k in range(3)],
            i0,
            i1,
            f,
        )

    centre_r, _, _, _ = at(right, y, xc)
    total = weights = 0.0
    for dy in range(-c["RADIUS"], c["RADIUS"] + 1):
        for dx in range(-c["RADIUS"], c["RADIUS"] + 1):
            yy, xx = y + dy, x + dx
            if not (0 <= yy < height and 0 <= xx < width) or not 0 <= xx - d <= width - 1:
                continue
            match, i0, i1, f = at(right, yy, xx - d)
            g_left = max(abs(int(left[k, yy, xx]) - int(left[k, y, x])) for k in range(3))
            g_right = max(abs(match[k] - centre_r[k]) for k in range(3))
            colour = (
                min(sum(abs(float(left[k, yy, xx]) - match[k]) for k in range(3)), c["TRUNCATION"])
                / 3
            )
            h = (1 - f) * hamming(codes_l[yy, xx], codes_r[yy, i0]) + f * hamming(
                codes_l[yy, xx], codes_r[yy, i1]
            )
            e = 2 - math.exp(-h / c["CENSUS_SCALE"]) - math.exp(-colour / c["COLOUR_COST_SCALE"])
            w = (
                math.exp(-g_left / c["COLOUR_SCALE"])
                * math.exp(-min(int(g_right + 0.5), 255) / c["COLOUR_SCALE"])
                * math.exp(-math.hypot(dy, dx) / c["SPACE_SCALE"])
            )
            total += w * e
            weights += w
    return total / weights if weights > 0 else math.inf


def candidates(d, left, flags, y, x, c):
    height, width = d.shape
    found = []
    for sy, sx in DIRECTIONS:
        for r in range(1, c["REACH"] + 1):
            yy, xx = y + sy * r, x + sx * r
            if not (0 <= yy < height and 0 <= xx < width):
                break
            if (
                max(abs(int(left[k, yy, xx]) - int(left[k, y, x])) for k in range(3))
                > c["COLOUR_LIMIT"]
            ):
                break
            if not abs(d[yy, xx] - d[yy - sy, xx - sx]) > 1.0:
                continue
            v = d[yy, xx]
            if v < d[y, x] and flags[yy, xx] == 0 and all(abs(u - v) >= 0.5 for u in found):
                found.append(v)
            break
    return found


def refine(d, flags, left, right, c):
    """The re-decided map; ``left``, ``right`` ``(3, H, W)`` channels."""
    height, width = d.shape
    codes_l = census(left.astype(np.float32).mean(axis=0), c["CENSUS_RADIUS"])
    codes_r = census(right.astype(np.float32).mean(axis=0), c["CENSUS_RADIUS"])
    out = d.copy()
    z = c["ZONE"]
    for y in range(height):
        for x in range(width):
            if not np.isfinite(d[y, x]):
                continue
            window = [
                d[min(max(y + dy, 0), height - 1), min(max(x + dx, 0), width - 1)]
                for dy in range(-z, z + 1)
                for dx in range(-z, z + 1)
            ]
            window = [v for v in window if np.isfinite(v)]
            if not max(window) - min(window) > c["JUMP"]:
                continue
            found = candidates(d, left, flags, y, x, c)
            if not found:
                continue
            best = cost(left, right, codes_l, codes_r, y, x, float(d[y, x]), c)
            bound = best * (1 - c["MARGIN"])
            for v in found:
                e = cost(left, right, codes_l, codes_r, y, x, float(v), c)
                if e < bound and e < best:
                    best, out[y, x] = e, v
    return out
