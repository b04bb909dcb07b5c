"""Slow, obviously correct twins of the row alignment's kernels (``costs.row_offsets``).

Each written from its docstring's definition, one patch, one pixel or one term at a time:
a value between two rows is ``(1 - t)`` times the upper row plus ``t`` times the lower,
read only where both rows are in the view.
"""

import math
from fractions import Fraction

import numpy as np


def row_between(view, row, columns):
    """The values of ``view`` at the fractional ``row`` and the whole ``columns``; None if out.

    Both rows of the interpolation (``floor(row)`` and the one below) must be in the view,
    and every column.
    """
    height, width = view.shape
    upper = math.floor(row)
    t = row - upper
    if upper < 0 or upper + 1 > height - 1 or min(columns) < 0 or max(columns) > width - 1:
        return None
    return np.array([(1.0 - t) * view[upper, x] + t * view[upper + 1, x] for x in columns])


def patch_at(view, centre_row, centre_column, radius):
    """The ``(2 radius + 1)^2`` patch of ``view`` around a fractional row; None if out."""
    columns = list(range(centre_column - radius, centre_column + radius + 1))
    rows = []
    for a in range(-radius, radius + 1):
        values = row_between(view, centre_row + a, columns)
        if values is None:
            return None
        rows.append(values)
    return np.array(rows)


def patch_cost(left_patch, right_patch):
    """The sum of absolute differences of two patches, each less its mean."""
    return float(
        np.abs((left_patch - left_patch.mean()) - (right_patch - right_patch.mean())).sum()
    )


def patch_curves(left, right, ys, xs, xr, centres, offsets, radius, reach):
    """Each patch's cost at each offset, ``(N, len(offsets))``; ``inf`` where a patch leaves.

    At ``o = centres[i] + offsets[j]``: the left patch around row ``ys[i] - o / 2``, column
    ``xs[i]``; the right patches around row ``ys[i] + o / 2``, columns ``xr[i] + dx``,
    ``dx`` in ``-reach..reach``; the least cost over ``dx``, lowered by half the difference
    of its two neighbours' costs when it has both (the vertex of the V through the three),
    but not below 0.
    Any patch, at any ``dx``, leaving its view gives ``inf``.
    """
    out = np.full((len(ys), len(offsets)), np.inf)
    for i in range(len(ys)):
        for j in range(len(offsets)):
            o = centres[i] + offsets[j]
            left_patch = patch_at(left, ys[i] - o / 2, xs[i], radius)
            right_patches = [
                patch_at(right, ys[i] + o / 2, xr[i] + dx, radius)
                for dx in range(-reach, reach + 1)
            ]
            if left_patch is None or any(p is None for p in right_patches):
                continue
            costs = [patch_cost(left_patch, p) for p in right_patches]
            k = min(range(len(costs)), key=lambda n: (costs[n], n))  # the first least
            best = costs[k]
            if 0 < k < len(costs) - 1:
                best = max(best - abs(costs[k - 1] - costs[k + 1]) / 2, 0.0)
            out[i, j] = best
    return out


def row_texture(luma, ys, xs, radius):
    """Each patch's mean of ``|luma[y + 1, x] - luma[y, x]|`` over its pairs of rows."""
    out = np.empty(len(ys))
    for i in range(len(ys)):
        differences = [
            abs(float(luma[y + 1, x]) - float(luma[y, x]))
            for y in range(ys[i] - radius, ys[i] + radius)
            for x in range(xs[i] - radius, xs[i] + radius + 1)
        ]
        out[i] = sum(differences) / len(differences)
    return out


def shift_rows(signal, offsets):
    """``signal`` (``(H, W)`` or ``(C, H, W)``) with pixel ``(y, x)`` read at row
    ``y + offsets[y, x]``, the rows beyond the view clamped to its first or last: integers
    in exact fractions, rounded half up; floats interpolated as they are. The dtype kept."""
    planes = signal[np.newaxis] if signal.ndim == 2 else signal
    channels, height, width = planes.shape
    integers = np.issubdtype(signal.dtype, np.integer)
    out = np.empty_like(planes)
    for y in range(height):
        for x in range(width):
            row = Fraction(y) + Fraction(float(offsets[y, x]))
            row = min(max(row, Fraction(0)), Fraction(height - 1))
            upper = math.floor(row)
            t = row - upper
            lower = min(upper + 1, height - 1)
            for c in range(channels):
                if integers:
                    value = (1 - t) * int(planes[c, upper, x]) + t * int(planes[c, lower, x])
                    out[c, y, x] = math.floor(value + Fraction(1, 2))
                else:
                    a, b = float(planes[c, upper, x]), float(planes[c, lower, x])
                    out[c, y, x] = (1 - float(t)) * a + float(t) * b
    return out[0] if signal.ndim == 2 else out


def field_offsets(coefficients, tiles, width, height):
    """``a + b u + c v + e u v + f v^2`` at every pixel, ``u``, ``v`` held within the tiles."""
    a, b, c, e, f = (float(k) for k in coefficients)
    tile_u = [x / width - 0.5 for x in tiles[:, 1]]
    tile_v = [y / height - 0.5 for y in tiles[:, 0]]
    out = np.empty((height, width))
    for y in range(height):
        v = min(max(y / height - 0.5, min(tile_v)), max(tile_v))
        for x in range(width):
            u = min(max(x / width - 0.5, min(tile_u)), max(tile_u))
            out[y, x] = a + b * u + c * v + e * u * v + f * v * v
    return out
