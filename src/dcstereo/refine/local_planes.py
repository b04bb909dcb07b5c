"""A plane through each pixel's window: slanted surfaces after the weighted median.

The medians (:mod:`dcstereo.refine.postfilter`, :mod:`dcstereo.refine.weighted_median`)
give a pixel one of its window's values, so that a slanted surface keeps the steps of a
matcher that prefers whole disparities between neighbours. :func:`local_plane_filter`
fits a plane ``d = a dx + b dy + c`` by weighted least squares to the estimates of a
pixel's window that lie within ``tolerance`` of its own (its surface; the other side of a
depth edge does not count), each weighed as by the weighted median, by how like the
pixel's its colour is and how near it lies (``exp(-g / colour_scale)`` times the weighted
median's integer table of the distance, in float32), and gives the pixel the plane's value
there.
A per-pixel slanted plane, as the slanted support windows of PatchMatch stereo (Bleyer et
al., BMVC 2011) give, here fitted to the estimates instead of searched for by their costs.

``dcstereo.match(..., median="weighted-planes")`` runs it after the weighted median.
"""

from dataclasses import replace

import numba as nb
import numpy as np

from dcstereo._checks import is_number
from dcstereo.refine import _local_planes as kernels
from dcstereo.refine.postfilter import _inside
from dcstereo.refine.weighted_median import (
    COLOUR_SCALE,
    RADIUS,
    SPACE_SCALE,
    checked_guide,
    kernel_guide,
    weight_tables,
)
from dcstereo.result import FLAG_FEATURE, DisparityResult

__all__ = ["colour_powers", "local_plane_filter", "local_planes"]

#: Estimates further than this (pixels) from the pixel's own do not count: 2 gained the
#: outdoor scenes a little and lost indoors, 0.6 lost a little everywhere.
TOLERANCE = 1.0


def colour_powers(colour_scale: float) -> np.ndarray:
    """Return ``exp(-2**b / colour_scale)`` for ``b`` in 0..7 (float32).

    The product of those of the bits of a colour difference ``g`` (0..255) is its colour
    factor ``exp(-g / colour_scale)``, to float32's precision.

    >>> p = colour_powers(20.0)
    >>> bool(np.isclose(p[0] * p[2], np.exp(-5 / 20.0)))
    True
    """
    return np.exp(-(2.0 ** np.arange(8)) / colour_scale).astype(np.float32)


def local_plane_filter(result: DisparityResult, left: np.ndarray, radius: int = RADIUS,
                       colour_scale: float = COLOUR_SCALE, space_scale: float = SPACE_SCALE,
                       tolerance: float = TOLERANCE) -> DisparityResult:  # fmt: skip
    """Return ``result`` with each estimate the value of its window's weighted plane.

    Parameters
    ----------
    result : DisparityResult
        From :func:`dcstereo.match` (filled or not), best after a median.
    left : ndarray
        The left image the map belongs to (gray or colour): the guide.
    radius : int
        Half the window's side (from 1); the window is cut at the image's edges.
    colour_scale, space_scale : float
        The colour difference and the distance that divide a weight by e (positive), as
        :func:`~dcstereo.refine.weighted_median.weighted_median_filter`'s.
    tolerance : float
        The estimates within this many pixels of the pixel's own count (non-negative).

    Returns
    -------
    DisparityResult
        The same flags, occlusions and features (the feature pixels keep their values);
        each other estimate moves to its plane's value, limited as the medians limit theirs
        to the disparities its pixel can have.

    Examples
    --------
    A ramp stays a ramp (within the slopes' light regularisation):

    >>> import numpy as np
    >>> from dcstereo.params import MatchParams
    >>> from dcstereo.refine.local_planes import local_plane_filter
    >>> from dcstereo.result import DisparityResult
    >>> d = np.tile(np.arange(12, dtype=np.float32) / 4, (9, 1))
    >>> params = MatchParams(max_disparity=20, method="sgm")
    >>> result = DisparityResult(d, np.zeros(d.shape, np.uint8), params, np.zeros(9))
    >>> gray = np.full((9, 12), 128, dtype=np.uint8)
    >>> bool(np.allclose(local_plane_filter(result, gray).disparity, d, atol=1e-3))
    True
    """
    guide = checked_guide(result, left, radius, colour_scale, space_scale)
    if not (is_number(tolerance) and np.isfinite(tolerance) and tolerance >= 0):
        raise ValueError(f"tolerance must be a non-negative number, got {tolerance!r}")
    d = np.ascontiguousarray(result.disparity, dtype=np.float32)
    moved = np.isfinite(d) & ((result.flags & FLAG_FEATURE) == 0)
    out = local_planes(d, guide, moved, int(radius), float(tolerance), float(colour_scale),
                       float(space_scale))  # fmt: skip
    return replace(result, disparity=_inside(out, result))


def local_planes(
    disparity: np.ndarray,
    guide: np.ndarray,
    moved: np.ndarray,
    radius: int,
    tolerance: float,
    colour_scale: float,
    space_scale: float,
) -> np.ndarray:
    """Return ``disparity`` (float32) with each ``moved`` pixel's plane value (the kernel).

    ``guide``: ``(C, H, W)`` levels 0..255 (:func:`dcstereo.signal.colour_channels`), one
    or three channels; the weights: :func:`colour_powers` and the distance table of
    :func:`~dcstereo.refine.weighted_median.weight_tables`. See
    ``dcstereo.refine._local_planes.local_plane_rows``; nothing is limited here.
    """
    disparity = np.ascontiguousarray(disparity, dtype=np.float32)
    _, space = weight_tables(radius, colour_scale, space_scale)
    out = np.empty_like(disparity)
    kernels.local_plane_rows(
        disparity, kernel_guide(guide), np.ascontiguousarray(moved), radius, tolerance,
        colour_powers(colour_scale), space.astype(np.float32), out, nb.get_num_threads(),
    )  # fmt: skip
    return out
