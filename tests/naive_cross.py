"""Slow, obviously correct twin of the cross-based aggregation (``kernels.cross_support``).

Plain loops, one definition at a time: the arms by the three rules of ADCensus, then each
pass as an explicit sum over the arm and the rounded mean the kernels compute.
"""

import numpy as np


def arm_length(colour, y, x, dy, dx, limit1, limit2, tau1, tau2):
    """Pixels past ``(y, x)`` in direction ``(dy, dx)`` that join its arm."""
    _, height, width = colour.shape
    centre = colour[:, y, x].astype(np.int64)
    length = 0
    for t in range(1, limit1):
        yy, xx = y + t * dy, x + t * dx
        if not (0 <= yy < height and 0 <= xx < width):
            break
        here = colour[:, yy, xx].astype(np.int64)
        previous = colour[:, yy - dy, xx - dx].astype(np.int64)
        to_centre = np.abs(here - centre).max()
        if to_centre >= tau1 or np.abs(here - previous).max() >= tau1:
            break
        if t > limit2 and to_centre >= tau2:
            break
        length = t
    return length


def arms(colour, limit1, limit2, tau1, tau2):
    """``(4, H, W)``: left, right, up and down arm lengths."""
    _, height, width = colour.shape
    out = np.zeros((4, height, width), dtype=np.int32)
    for y in range(height):
        for x in range(width):
            for i, (dy, dx) in enumerate(((0, -1), (0, 1), (-1, 0), (1, 0))):
                out[i, y, x] = arm_length(colour, y, x, dy, dx, limit1, limit2, tau1, tau2)
    return out


def rounded_mean(total, count):
    """The kernels' mean: ``int(float32(total) * (1 / float32(count)) + 0.5)`` in float32."""
    scale = np.float32(1.0) / np.float32(count)
    return int(np.float32(np.float32(total) * scale) + np.float32(0.5))


def horizontal(volume, arm, ndisp):
    """Each lane ``k < ndisp`` averaged over the pixel's horizontal arm."""
    out = volume.copy()
    height, width, _ = volume.shape
    for y in range(height):
        for x in range(width):
            lo, hi = x - arm[0, y, x], x + arm[1, y, x]
            for k in range(ndisp):
                total = int(volume[y, lo : hi + 1, k].astype(np.int64).sum())
                out[y, x, k] = rounded_mean(total, hi - lo + 1)
    return out


def vertical(volume, arm, ndisp):
    """Each lane ``k < ndisp`` averaged over the pixel's vertical arm."""
    out = volume.copy()
    height, width, _ = volume.shape
    for y in range(height):
        for x in range(width):
            lo, hi = y - arm[2, y, x], y + arm[3, y, x]
            for k in range(ndisp):
                total = int(volume[lo : hi + 1, x, k].astype(np.int64).sum())
                out[y, x, k] = rounded_mean(total, hi - lo + 1)
    return out


def cross_aggregate(volume, colour, ndisp, limit, tau, iterations):
    """The rounds of ``dcstereo.aggregate.cross.cross_aggregate``: H then V, V then H, ..."""
    arm = arms(colour, limit, limit // 2, tau, max(1, round(0.3 * tau)))
    for i in range(iterations):
        if i % 2 == 0:
            volume = vertical(horizontal(volume, arm, ndisp), arm, ndisp)
        else:
            volume = horizontal(vertical(volume, arm, ndisp), arm, ndisp)
    return volume


def horizontal_both(volume, arm, arm_r, dmin, ndisp):
    """``horizontal`` over the arms both views share: the shorter of left pixel ``x``'s and
    right pixel ``x - d``'s (clamped to the image) on each side, at each disparity."""
    out = volume.copy()
    height, width, _ = volume.shape
    for y in range(height):
        for x in range(width):
            for k in range(ndisp):
                xr = min(max(x - dmin - k, 0), width - 1)
                lo = x - min(arm[0, y, x], arm_r[0, y, xr])
                hi = x + min(arm[1, y, x], arm_r[1, y, xr])
                total = int(volume[y, lo : hi + 1, k].astype(np.int64).sum())
                out[y, x, k] = rounded_mean(total, hi - lo + 1)
    return out


def vertical_both(volume, arm, arm_r, dmin, ndisp):
    """``vertical`` over the arms both views share (as ``horizontal_both``)."""
    out = volume.copy()
    height, width, _ = volume.shape
    for y in range(height):
        for x in range(width):
            for k in range(ndisp):
                xr = min(max(x - dmin - k, 0), width - 1)
                lo = y - min(arm[2, y, x], arm_r[2, y, xr])
                hi = y + min(arm[3, y, x], arm_r[3, y, xr])
                total = int(volume[lo : hi + 1, x, k].astype(np.int64).sum())
                out[y, x, k] = rounded_mean(total, hi - lo + 1)
    return out


def cross_aggregate_both(volume, colour, colour_r, dmin, ndisp, limit, tau, iterations):
    """``cross_aggregate`` with the arms both views share (``aggregation="cross-both"``)."""
    tight = max(1, round(0.3 * tau))
    arm = arms(colour, limit, limit // 2, tau, tight)
    arm_r = arms(colour_r, limit, limit // 2, tau, tight)
    for i in range(iterations):
        if i % 2 == 0:
            volume = horizontal_both(volume, arm, arm_r, dmin, ndisp)
            volume = vertical_both(volume, arm, arm_r, dmin, ndisp)
        else:
            volume = vertical_both(volume, arm, arm_r, dmin, ndisp)
            volume = horizontal_both(volume, arm, arm_r, dmin, ndisp)
    return volume
