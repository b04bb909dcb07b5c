"""Cross-based aggregation of a cost volume (``aggregation="cross"`` of ``sgm``).

The costs of each pixel are averaged over a support region that follows the left view's
colours: the cross of Zhang et al. (2009) with the arm rules of ADCensus (Mei et al. 2011),
see :mod:`dcstereo.aggregate._cross`. Weakly textured surfaces get wide regions (up to
``cross_limit`` pixels each way) before the semi-global aggregation, edges narrow ones.
"""

import numpy as np

from dcstereo.aggregate import _cross as kernels


def tight_colour(tau: int) -> int:
    """Return the colour bound of long arms (ADCensus's ``tau2``: 6 for ``tau1`` 20)."""
    return max(1, round(0.3 * tau))


def support_arms(colour: np.ndarray, limit: int, tau: int) -> np.ndarray:
    """Return the ``(4, H, W)`` int32 arms (left, right, up, down) of ``colour`` ``(C, H, W)``.

    ``limit``: the arms are shorter than ``limit`` pixels (beyond ``limit // 2`` only pixels
    within :func:`tight_colour` of the centre join); ``tau``: the largest channel difference
    (0..255 scale, exclusive) to the centre and to the previous pixel of the arm.
    """
    colour = np.ascontiguousarray(colour)
    arms = np.empty((4,) + colour.shape[1:], dtype=np.int32)
    kernels.cross_arms(colour, limit, limit // 2, tau, tight_colour(tau), arms)
    return arms


def cross_aggregate(
    volume: np.ndarray,
    colour: np.ndarray,
    ndisp: int,
    *,
    limit: int,
    tau: int,
    iterations: int,
    colour_r: np.ndarray | None = None,
    dmin: int = 0,
) -> None:
    """Average ``volume`` (``(H, W, Dp)`` int16) in place over the cross regions of ``colour``.

    ``iterations`` rounds of a horizontal and a vertical pass, the odd rounds horizontal
    first and the even ones vertical first (as ADCensus alternates them). Only the lanes
    ``k < ndisp`` change. Memory: an int32 scratch of ``(H, W, ndisp)`` for the vertical
    passes. With ``colour_r`` (the right view's ``(C, H, W)``): the regions both views
    share at each disparity ``dmin + k`` (``aggregation="cross-both"``; ADCensus combines
    the two views' arms so), the shorter of left pixel ``x``'s and right pixel ``x - d``'s
    arms on each side.
    """
    arms = support_arms(colour, limit, tau)
    prefix = np.empty(volume.shape[:2] + (ndisp,), dtype=np.int32)
    if colour_r is not None:  # the arms both views share at each disparity
        arms_r = support_arms(colour_r, limit, tau)
        counts = np.arange(2 * limit + 1, dtype=np.float32)
        counts[0] = 1
        reciprocals = np.float32(1.0) / counts
        for i in range(iterations):
            if i % 2 == 0:
                kernels.aggregate_horizontal_both(volume, arms, arms_r, dmin, ndisp, reciprocals)
                kernels.aggregate_vertical_both(
                    volume, arms, arms_r, dmin, ndisp, reciprocals, prefix
                )
            else:
                kernels.aggregate_vertical_both(
                    volume, arms, arms_r, dmin, ndisp, reciprocals, prefix
                )
                kernels.aggregate_horizontal_both(volume, arms, arms_r, dmin, ndisp, reciprocals)
        return
    for i in range(iterations):
        if i % 2 == 0:
            kernels.aggregate_horizontal(volume, arms, ndisp)
            kernels.aggregate_vertical(volume, arms, ndisp, prefix)
        else:
            kernels.aggregate_vertical(volume, arms, ndisp, prefix)
            kernels.aggregate_horizontal(volume, arms, ndisp)
