"""A median of the disparity map weighted by the left image: edges stay where the colours are.

The plain median (:mod:`dcstereo.refine.postfilter`) counts every estimate of its window
alike, so that near a depth edge the window's other surface pulls a pixel across it, and a
thin structure narrower than half the window is voted away. The weighted median of stereo's
post-processing (as in Ma et al., *Constant Time Weighted Median Filtering for Stereo
Matching and Beyond*, ICCV 2013, and the cost-filtering pipelines before it) counts each
estimate of the window by how like the centre pixel its colour is and how near it lies:
``exp(-g / colour_scale - r / space_scale)``, ``g`` the largest difference of a channel of
the left image (0..255) and ``r`` the distance in pixels. A pixel then takes the median of
the estimates of its own surface, and a streak or spike of a few pixels across a region of
one colour goes.

``dcstereo.match(..., median="weighted")`` runs it in place of the plain median, with the
parameters below (measured on the development scenes: ``scripts/eval_stages.py``).
"""

import functools
from dataclasses import replace

import numba as nb
import numpy as np

from dcstereo.refine import _weighted_median as kernels
from dcstereo.refine._median import window_plan
from dcstereo.refine.postfilter import _inside
from dcstereo.result import FLAG_FEATURE, DisparityResult
from dcstereo.signal import colour_channels

__all__ = ["weight_tables", "weighted_median_filter"]

#: The window's half side (a 9 x 9 window): 3 (7 x 7) lost 0.04 points of bad-1.0 on the
#: development scenes, 5 (11 x 11) 0.05 on the newer ones (docs/guide/methods.md).
RADIUS = 4
#: Colour differences (0..255, the largest of the channels) that divide a weight by e.
COLOUR_SCALE = 20.0
#: Distances (pixels) that divide a weight by e.
SPACE_SCALE = 3.0
#: The weights are integers, ``UNIT`` for the centre pixel, so that their sums are exact in
#: any order and the median does not depend on it.
UNIT = 1024


def weight_tables(radius: int = RADIUS, colour_scale: float = COLOUR_SCALE,
                  space_scale: float = SPACE_SCALE) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Return the integer weight tables: by colour difference (256) and by offset (square).

    ``colour[g] = round(UNIT * exp(-g / colour_scale))`` for ``g`` in 0..255 and
    ``space[dy + radius, dx + radius] = round(UNIT * exp(-hypot(dy, dx) / space_scale))``,
    both int64; a sample weighs their product.

    >>> colour, space = weight_tables(1, 20.0, 3.0)
    >>> int(colour[0]), int(colour[20]), space.tolist()
    (1024, 377, [[639, 734, 639], [734, 1024, 734], [639, 734, 639]])
    """
    levels = np.arange(256, dtype=np.float64)
    colour = np.rint(UNIT * np.exp(-levels / colour_scale)).astype(np.int64)
    offsets = np.arange(-radius, radius + 1, dtype=np.float64)
    distance = np.hypot(offsets[:, None], offsets[None, :])
    space = np.rint(UNIT * np.exp(-distance / space_scale)).astype(np.int64)
    return colour, space


def weighted_median_filter(result: DisparityResult, left: np.ndarray, radius: int = RADIUS,
                           colour_scale: float = COLOUR_SCALE,
                           space_scale: float = SPACE_SCALE) -> DisparityResult:  # fmt: skip
    """Return ``result`` with each estimate replaced by its window's colour-weighted median.

    Parameters
    ----------
    result : DisparityResult
        From :func:`dcstereo.match` (filled or not).
    left : ndarray
        The left image the map belongs to (gray or colour, any of the library's input
        types): the guide.
    radius : int
        Half the window's side (from 1); the window is cut at the image's edges.
    colour_scale, space_scale : float
        The colour difference and the distance that divide a weight by e (positive).

    Returns
    -------
    DisparityResult
        As :func:`~dcstereo.refine.postfilter.median_filter` returns it: the same flags,
        occlusions and features (the feature pixels keep their values); only the estimates
        count and move, and one that moved outside the disparities its pixel can have is
        limited to the nearest of them.

    Examples
    --------
    >>> import numpy as np, dcstereo
    >>> from dcstereo.refine.weighted_median import weighted_median_filter
    >>> rng = np.random.default_rng(0)
    >>> right = rng.integers(0, 256, (20, 40), dtype=np.uint8)
    >>> left = np.roll(right, 3, axis=1)
    >>> result = dcstereo.match(left, right, max_disparity=6, method="dc")
    >>> float(np.nanmedian(weighted_median_filter(result, left).disparity))
    3.0
    """
    guide = checked_guide(result, left, radius, colour_scale, space_scale)
    d = result.disparity
    moved = np.isfinite(d) & ((result.flags & FLAG_FEATURE) == 0)
    colour, space = weight_tables(int(radius), float(colour_scale), float(space_scale))
    out = weighted_medians(d, guide, moved, int(radius), colour, space)
    return replace(result, disparity=_inside(out, result))


def checked_guide(result, left, radius, colour_scale, space_scale) -> np.ndarray:
    """Return ``left``'s channels ``(C, H, W)`` for a window filter of ``result``'s map.

    Raises TypeError or ValueError naming the argument: ``result`` not a
    :class:`~dcstereo.result.DisparityResult`, ``radius`` not a positive integer, a scale
    not a positive number, ``left`` not of the map's shape. Shared by the filters guided
    by the left image (:func:`weighted_median_filter`,
    :func:`dcstereo.refine.local_planes.local_plane_filter`).
    """
    if not isinstance(result, DisparityResult):
        raise TypeError(f"result must be a DisparityResult, got {type(result).__name__}")
    if isinstance(radius, bool) or not isinstance(radius, int | np.integer) or radius < 1:
        raise ValueError(f"radius must be a positive integer, got {radius!r}")
    for name, value in (("colour_scale", colour_scale), ("space_scale", space_scale)):
        if not (isinstance(value, int | float) and np.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive number, got {value!r}")
    guide, _ = colour_channels(left, left)
    if guide.shape[1:] != result.disparity.shape:
        raise ValueError(
            f"left has shape {guide.shape[1:]} but the disparity map {result.disparity.shape}"
        )
    return guide


def kernel_guide(guide: np.ndarray) -> np.ndarray:
    """Return ``guide`` (``(C, H, W)``) as the guided kernels read it: three contiguous channels.

    A gray guide (one channel) becomes three equal ones: the same largest difference. The
    weighted median's and the local planes' kernels both read three.
    """
    if guide.shape[0] == 1:
        guide = np.repeat(guide, 3, axis=0)
    return np.ascontiguousarray(guide)


def weighted_medians(
    disparity: np.ndarray,
    guide: np.ndarray,
    moved: np.ndarray,
    radius: int,
    colour_weight: np.ndarray,
    space_weight: np.ndarray,
) -> np.ndarray:
    """Return ``disparity`` (float32) with each ``moved`` pixel's weighted median (the kernel).

    ``guide``: ``(C, H, W)`` levels 0..255 (:func:`dcstereo.signal.colour_channels`);
    ``colour_weight``, ``space_weight``: :func:`weight_tables` (the distance's table
    symmetric about its centre: the kernel takes a pixel's weight of its sample at ``-o``
    from the sample's of it at ``o``; ValueError otherwise). See
    :func:`dcstereo.refine._weighted_median.weighted_median_rows`; a zero comes out as +0.0.
    """
    if not np.array_equal(space_weight, space_weight[::-1, ::-1]):
        raise ValueError("space_weight must be symmetric about its centre (a distance's weight)")
    disparity = np.ascontiguousarray(disparity, dtype=np.float32)
    out = disparity.copy()
    keys = np.empty(disparity.shape, dtype=np.int32)
    kernels.sample_keys(disparity.view(np.int32), keys)
    count = (2 * radius + 1) ** 2
    largest = 2 * count * int(colour_weight.max()) * int(space_weight.max())
    sums = np.int32 if largest < 2**31 else np.int64  # int32: twice the lanes (1.14x)
    kernels.weighted_median_rows(
        keys, kernel_guide(guide), np.ascontiguousarray(moved), radius,
        colour_weight.astype(np.int32), space_weight.astype(np.int32), _plan(2 * radius + 1),
        np.empty(0, dtype=sums), out.view(np.int32), nb.get_num_threads(),
    )  # fmt: skip
    return out


@functools.cache
def _plan(side: int) -> tuple[np.ndarray, ...]:
    return window_plan(side)
