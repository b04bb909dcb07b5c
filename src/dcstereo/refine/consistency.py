"""Fill what a left-right check removed: occlusions and mismatches, each its own way.

Occlusions are filled from the background, mismatches from their most similar neighbour.
A left pixel fails the check of :mod:`dcstereo.methods.sgm` either because the right view cannot
see it (an occlusion: its right pixel belongs to a nearer surface,
:data:`~dcstereo.result.FLAG_OCCLUDED`, or lies beyond the image,
:data:`~dcstereo.result.FLAG_BORDER`) or because its match was simply wrong (a mismatch,
:data:`~dcstereo.result.FLAG_MISMATCH`). The two are filled differently (Hirschmueller
2008, section 4.3, makes the same distinction):

* an occluded pixel lies on the background, so it takes the smaller of the nearest
  estimates to its left and right on its row (:func:`dcstereo.fill_occlusions`);
* a mismatched pixel lies on whatever surface surrounds it, so it takes the estimate of the
  pixel, among the first with an estimate along eight directions, whose colour is closest
  to its own: the search does not cross into a surface of another colour, so the fill
  follows the left image's edges.
"""

from dataclasses import replace

import numpy as np

from dcstereo.refine import _consistency as _kernels
from dcstereo.result import (
    FLAG_BORDER,
    FLAG_FILLED,
    FLAG_MISMATCH,
    FLAG_OCCLUDED,
    DisparityResult,
    check_result_pair,
)
from dcstereo.signal import colour_channels


def fill_inconsistent(result: DisparityResult, left: np.ndarray) -> DisparityResult:
    """Fill the pixels of ``result`` without an estimate: occlusions and mismatches.

    Parameters
    ----------
    result : DisparityResult
        A map whose missing pixels carry their reason flags (:func:`dcstereo.match` with
        ``fill=False``).
    left : ndarray, shape (H, W) or (H, W, 3|4)
        The left image, whose colours guide the fill of the mismatches.

    Returns
    -------
    DisparityResult
        Every pixel without an estimate filled where any estimate exists (occlusions and
        border pixels from the background of their row, mismatches from their most
        similar neighbour, the rest from the background), flagged
        :data:`~dcstereo.result.FLAG_FILLED` beside its reason.

    Examples
    --------
    >>> import numpy as np, dcstereo
    >>> from dcstereo.refine.consistency import fill_inconsistent
    >>> rng = np.random.default_rng(0)
    >>> right = rng.integers(0, 256, (30, 60), dtype=np.uint8)
    >>> left = np.roll(right, 4, axis=1)
    >>> raw = dcstereo.match(left, right, max_disparity=8, method="sgm", fill=False)
    >>> filled = fill_inconsistent(raw, left)
    >>> bool(np.isnan(raw.disparity).any()), bool(np.isnan(filled.disparity).any())
    (True, False)
    """
    check_result_pair(result, left, left)
    return fill_with_colour(result, colour_channels(left, left)[0])


def fill_with_colour(result: DisparityResult, colour: np.ndarray) -> DisparityResult:
    """:func:`fill_inconsistent` with the left image's channels given: ``(C, H, W)`` int16."""
    disparity = result.disparity
    out = np.empty_like(disparity)
    _kernels.fill_rows(disparity, (result.flags & FLAG_MISMATCH) != 0, colour, out)
    filled = np.isnan(disparity) & np.isfinite(out)
    flags = result.flags | (filled.view(np.uint8) * np.uint8(FLAG_FILLED))
    return replace(result, disparity=out, flags=flags)


__all__ = ["FLAG_BORDER", "FLAG_MISMATCH", "FLAG_OCCLUDED", "fill_inconsistent"]
