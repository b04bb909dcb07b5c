"""A median filter of the disparity map: the post-filter of CNES Pandora's pipeline.

A scanline DP decides each row on its own, so its maps carry short horizontal streaks and
single-row spikes where neighbouring rows agree. :func:`median_filter` gives every pixel
with an estimate the median of the estimates in the square window around it; a pixel
without one (occluded, beyond the border) stays without, so the occlusion map and the flags
do not change, and the feature pairs of the ``dc`` methods keep their disparities (they are
the matches the method trusts most, and its path passes through them).

``dcstereo.match(..., median=5)`` runs it inside the match, after ``subpixel`` and before
``fill``: the filled pixels then take the filtered background.
"""

import functools
from dataclasses import replace

import numpy as np

from dcstereo.params import MAX_MEDIAN, check_median
from dcstereo.refine import _median as median_kernels
from dcstereo.refine import _postfilter as postfilter_kernels
from dcstereo.result import FLAG_FEATURE, FLAG_FILLED, DisparityResult

__all__ = ["MAX_MEDIAN", "median_filter"]


def median_filter(result: DisparityResult, size: int = 5) -> DisparityResult:
    """Return ``result`` with each estimate replaced by the median of those around it.

    Parameters
    ----------
    result : DisparityResult
        From :func:`dcstereo.match` (filled or not).
    size : int
        Odd side of the square window, 3 to :data:`MAX_MEDIAN`. The window is cut at the
        image's edges; only the pixels with an estimate in it count (of an even count,
        the mean of the middle two).

    Returns
    -------
    DisparityResult
        The same flags, occlusions and features; the feature pixels keep their values. A
        median of an estimate (not of a filled pixel) that moved outside the disparities the
        pixel can have (the searched range, ``x - d`` inside the right image, from -0.5 to
        ``width - 0.5``) is limited to
        the nearest of them.

    Examples
    --------
    >>> import numpy as np, dcstereo
    >>> from dcstereo.refine.postfilter import median_filter
    >>> rng = np.random.default_rng(0)
    >>> right = rng.integers(0, 256, (20, 40), dtype=np.uint8)
    >>> left = np.roll(right, 3, axis=1)
    >>> result = dcstereo.match(left, right, max_disparity=6, method="dc")  # no median of its own
    >>> float(np.nanmedian(median_filter(result, 3).disparity))
    3.0
    """
    if not isinstance(result, DisparityResult):
        raise TypeError(f"result must be a DisparityResult, got {type(result).__name__}")
    size = check_median(size, "size")
    if size == 0 or isinstance(size, str):
        raise ValueError(
            f"size must be an odd integer from 3, got {size!r} (the weighted median: "
            "dcstereo.refine.weighted_median.weighted_median_filter)"
        )
    d = result.disparity
    moved = np.isfinite(d) & ((result.flags & FLAG_FEATURE) == 0)
    out = d.copy()
    radius = size // 2
    full = moved & _full_windows(d, radius)
    if full.any():  # every value of the window finite: a sorting network, rows at a time
        median_kernels.median_rows_network(
            _bits(d), radius, _network(size), full, out.view(np.int32)
        )
        moved = moved & ~full
        if moved.any():  # the rest (windows with holes, or cut by the edge): sorted one by one
            postfilter_kernels.median_rows(d, moved, radius, out)
        return replace(result, disparity=_inside(out, result))
    bins = np.empty(d.shape, dtype=np.int32)
    low, nbins, exact = postfilter_kernels.value_buckets(d, MAX_BINS, bins)
    if nbins:  # a histogram of value buckets slid along the rows
        postfilter_kernels.median_rows_binned(d, bins, moved, radius, nbins, low, exact, out)
    else:  # a span too wide for the histogram: each window sorted
        postfilter_kernels.median_rows(d, moved, radius, out)
    return replace(result, disparity=_inside(out, result))


def _inside(out: np.ndarray, result: DisparityResult) -> np.ndarray:
    """Limit the medians of the method's own estimates to the disparities they can have.

    Near the left edge the window's median can exceed the column by more than half a pixel
    (a match left of the right image's first pixel); an estimate whose median moved there
    becomes the nearest disparity of the searched range that points inside the right image
    (``-0.5 <= x - d <= width - 0.5``: its pixels are a pixel wide). A filled pixel has
    no match in the right image, and its true disparity may well point outside it: it is
    only kept within the searched range (a median never leaves it; a fitted plane, as
    :mod:`dcstereo.refine.local_planes` fits, can, past the range's end). ``out`` (the
    stage's own new map) is limited in place and returned.
    """
    params = result.params
    bottom, top = np.float32(params.min_disparity), np.float32(params.max_disparity)
    filled = (result.flags & FLAG_FILLED) != 0
    least, largest = right_image_bounds(out.shape[1])
    postfilter_kernels.limit_inside(out, result.disparity, filled, least, largest, bottom, top)
    return out


def right_image_bounds(width: int) -> tuple[np.ndarray, np.ndarray]:
    """Return the least and the largest disparity of each column that point inside the right image.

    ``x - d`` from -0.5 to ``width - 0.5`` (its pixels are a pixel wide): float32 rows of
    ``x - (width - 0.5)`` and ``x + 0.5``.
    """
    cols = np.arange(width, dtype=np.float32)
    return cols - (width - 0.5), cols + 0.5


def _bits(d: np.ndarray) -> np.ndarray:
    """Return a float32 map's values as their int32 bits (the median network's input)."""
    return np.ascontiguousarray(d, dtype=np.float32).view(np.int32)


@functools.cache
def _network(size: int) -> np.ndarray:
    return median_kernels.median_network(size * size)


def _full_windows(disparity: np.ndarray, radius: int) -> np.ndarray:
    """Pixels whose ``2 radius + 1`` square lies inside the image and holds no NaN."""
    height, width = disparity.shape
    full = np.zeros(disparity.shape, dtype=bool)
    side = 2 * radius + 1
    if height < side or width < side:
        return full
    holes = np.isnan(disparity).astype(np.int32)
    if not holes.any():
        full[radius : height - radius, radius : width - radius] = True
        return full
    table = np.zeros((height + 1, width + 1), dtype=np.int64)  # summed-area table of holes
    table[1:, 1:] = holes.cumsum(axis=0).cumsum(axis=1)
    counts = (
        table[side:, side:] - table[:-side, side:] - table[side:, :-side] + table[:-side, :-side]
    )
    full[radius : height - radius, radius : width - radius] = counts == 0
    return full


#: The most histogram buckets the sliding histogram takes (a map of whole and half pixels
#: spanning 8192 pixels of disparity, a sub-pixel map 8192 at half-pixel buckets, 128 at the
#: finest); a map with a wider span has each window sorted instead.
MAX_BINS = 1 << 14
