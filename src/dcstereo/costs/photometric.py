"""The right view's colours mapped onto the left's, before ``sgm``'s colour term.

The census term compares the order of intensities in a window, so that a change of gain,
offset or gamma between the two views leaves it as it was; the absolute difference of the
colours does not. Global histogram matching (each channel of the right view mapped so that
its histogram is the left's) undoes any such change but also bends the colours where the
two views see different things (the strip only one view sees, the occluded regions): it
cost 0.3 points of bad-1.0 on the 2005/2006 and 2014 development scenes. Here the two
histograms are taken over the same scene points instead: the pixels that a coarse ``sgm``
pass (census alone, :data:`COARSE_FACTOR` times smaller each way) matched and kept through
its left-right check. With no change between the views the map stays near the identity;
with one, it undoes it.

:func:`box_down` makes the coarse views, :func:`pair_histograms` counts the colours of the
matched pairs, :func:`quantile_lut` maps each right level to the left level of the same
quantile and :func:`apply_luts` applies the maps; :func:`align_right` runs the last three.
"""

import numba as nb
import numpy as np

#: How many times smaller, each way, the coarse pass's views are (a 4 x 4 box mean).
COARSE_FACTOR = 4

#: The fewest pixels a coarse view needs on its shorter side; smaller pairs are not mapped.
MIN_COARSE_SIDE = 16

#: The fewest matched pairs that give a map; with fewer the right view is left as it is.
MIN_PAIRS = 1000

#: Colour levels (the 0..255 scale of :func:`dcstereo.signal.colour_channels`).
LEVELS = 256

#: Sub-histograms :func:`pair_histograms` counts into, by column (3.2 -> 2.0 ms on Piano).
WAYS = 4


@nb.njit(cache=True)
def box_down(colour, factor):
    """Return the ``factor x factor`` box means of ``colour`` (``(C, H, W)``), rounded.

    ``(H // factor, W // factor, C)`` uint8: the rows and columns past the last whole box
    are left out. Halves round up.
    """
    channels, height, width = colour.shape
    rows, cols = height // factor, width // factor
    out = np.empty((rows, cols, channels), dtype=np.uint8)
    area = factor * factor
    for c in range(channels):
        for y in range(rows):
            for x in range(cols):
                total = 0
                for dy in range(factor):
                    for dx in range(factor):
                        total += colour[c, y * factor + dy, x * factor + dx]
                out[y, x, c] = (2 * total + area) // (2 * area)
    return out


@nb.njit(cache=True)
def pair_histograms(colour_l, colour_r, coarse, factor, hist_l, hist_r):
    """Count the colours of the pixels ``coarse`` matches; return how many pairs.

    ``coarse``: the coarse pass's disparities (NaN: no estimate), ``factor`` times smaller
    each way. The left pixel ``(y, x)`` takes the disparity ``d = factor * coarse[y //
    factor, x // factor]`` (the last row and column of boxes reach the image's edge), and
    its partner is the right pixel ``(y, round(x - d))`` (halves to even) where that lies
    in the image. ``hist_l[c, v]`` and ``hist_r[c, v]`` (int64, ``(C, 256)``, overwritten)
    count the level ``v`` of channel ``c`` over the left pixels and over their partners
    (every element written).
    """
    channels, height, width = colour_l.shape
    rows, cols = coarse.shape
    # each count spread over WAYS sub-histograms by column (summed at the end): neighbours
    # mostly share a level, and one histogram would make each count wait for the last
    sub_l = np.zeros((channels, WAYS, LEVELS), dtype=np.int64)
    sub_r = np.zeros((channels, WAYS, LEVELS), dtype=np.int64)
    partner = np.empty(width, dtype=np.int64)  # a row's partner columns, -1: none
    pairs = 0
    for y in range(height):
        cy = min(y // factor, rows - 1)
        for x in range(width):
            d = coarse[cy, min(x // factor, cols - 1)]
            xr = -1
            if np.isfinite(d):
                xr = int(np.rint(x - factor * d))
                if xr >= width:
                    xr = -1
            partner[x] = xr
        for c in range(channels):
            row_l, row_r = colour_l[c, y], colour_r[c, y]
            for x in range(width):
                xr = partner[x]
                if xr >= 0:
                    way = x % WAYS
                    sub_l[c, way, row_l[x]] += 1
                    sub_r[c, way, row_r[xr]] += 1
        for x in range(width):
            if partner[x] >= 0:
                pairs += 1
    for c in range(channels):
        for v in range(LEVELS):
            hist_l[c, v] = sub_l[c, :, v].sum()
            hist_r[c, v] = sub_r[c, :, v].sum()
    return pairs


def quantile_lut(hist_source: np.ndarray, hist_target: np.ndarray) -> np.ndarray:
    """Return the map (int16, 256) of each source level to the target level of its quantile.

    A level's quantile is the share of the counts below it plus half its own (the middle of
    its step of the cumulative histogram). The target level of a quantile is interpolated
    linearly between the quantiles of the target's levels that occur (and held at the first
    and the last of them beyond), then rounded. Two equal histograms map each level that
    occurs onto itself. Both histograms must hold counts.
    """
    source = np.asarray(hist_source, dtype=np.float64)
    target = np.asarray(hist_target, dtype=np.float64)
    q_source = (np.cumsum(source) - 0.5 * source) / source.sum()
    q_target = (np.cumsum(target) - 0.5 * target) / target.sum()
    present = target > 0
    levels = np.arange(source.size, dtype=np.float64)
    return np.rint(np.interp(q_source, q_target[present], levels[present])).astype(np.int16)


@nb.njit(cache=True, parallel=True)
def apply_luts(colour, luts):
    """Return ``colour`` (``(C, H, W)`` int16, levels 0..255) with ``luts[c]`` on channel ``c``."""
    channels, height, width = colour.shape
    out = np.empty_like(colour)
    for y in nb.prange(height):
        for c in range(channels):
            lut = luts[c]
            for x in range(width):
                out[c, y, x] = lut[colour[c, y, x]]
    return out


def align_right(colour_l: np.ndarray, colour_r: np.ndarray, coarse: np.ndarray, factor: int):
    """Return the right view's channels mapped onto the left's through the matched pairs.

    ``colour_l``, ``colour_r``: ``(C, H, W)`` int16 (:func:`dcstereo.signal.colour_channels`);
    ``coarse``: the coarse pass's disparities (see :func:`pair_histograms`). With fewer
    than :data:`MIN_PAIRS` pairs, ``colour_r`` itself.
    """
    channels = colour_l.shape[0]
    hist_l = np.empty((channels, LEVELS), dtype=np.int64)  # filled by pair_histograms
    hist_r = np.empty((channels, LEVELS), dtype=np.int64)
    pairs = pair_histograms(colour_l, colour_r, coarse, factor, hist_l, hist_r)
    if pairs < MIN_PAIRS:
        return colour_r
    luts = np.stack([quantile_lut(hist_r[c], hist_l[c]) for c in range(channels)])
    return apply_luts(colour_r, luts)
