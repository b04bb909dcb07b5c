"""Robust planes per segment of the left image: a refinement of ``sgm``'s map.

Large weakly textured or slanted surfaces (a wall, a table, a floor) are where a
semi-global matcher leaves streaks and holes, but there the true disparity is close to a
plane over any small patch of one colour. :func:`segment_planes` cuts the left image into
superpixels (SLIC, :func:`superpixels`), fits a plane ``d = a x + b y + c`` to each
segment's trusted estimates by RANSAC and least squares (:func:`fit_planes`), and where a
segment's plane explains most of its estimates, gives the plane's value to its pixels
without an estimate and to those whose estimate is far from it.
"""

import numpy as np

from .kernels import planes as _kernels


def superpixels(colour: np.ndarray, step: int = 16, compactness: float = 20.0,
                iterations: int = 5) -> np.ndarray:  # fmt: skip
    """SLIC superpixels of ``colour`` (``(C, H, W)``, gray levels): ``(H, W)`` int32 labels.

    Labels are the cells of a grid of about ``step`` pixels (``gy * nx + gx``).
    """
    colour = np.ascontiguousarray(colour, dtype=np.float64)
    labels = np.empty(colour.shape[1:], dtype=np.int32)
    _kernels.slic(colour, int(step), float(compactness), int(iterations), labels)
    return labels


def fit_planes(disparity: np.ndarray, usable: np.ndarray, labels: np.ndarray, step: int,
               iterations: int = 200, inlier: float = 1.0, stop: float = 0.9):  # fmt: skip
    """Fit a plane to each segment's ``usable`` estimates; return ``(planes, support)``.

    ``planes``: ``(n, 3)`` float64, ``(a, b, c)`` of ``d = a x + b y + c``; ``support``:
    ``(n, 3)`` int64, (estimates used, inliers within ``inlier`` px, pixels of the segment).
    """
    height, width = disparity.shape
    ny, nx = _kernels.grid_shape(height, width, int(step))
    n = ny * nx
    planes = np.zeros((n, 3), dtype=np.float64)
    support = np.zeros((n, 3), dtype=np.int64)
    _kernels.fit_planes(
        np.ascontiguousarray(disparity, dtype=np.float64), np.ascontiguousarray(usable),
        labels, n, nx, int(iterations), float(inlier), float(stop), planes, support,
    )  # fmt: skip
    return planes, support


def segment_planes(
    disparity: np.ndarray,
    colour: np.ndarray,
    *,
    usable: np.ndarray | None = None,
    replaceable: np.ndarray | None = None,
    low: float = -np.inf,
    high: float = np.inf,
    step: int = 16,
    compactness: float = 20.0,
    slic_iterations: int = 5,
    iterations: int = 200,
    inlier: float = 1.0,
    outlier: float = 2.0,
    min_ratio: float = 0.6,
    min_support: float = 0.3,
    stop: float = 0.9,
) -> np.ndarray:
    """Refine ``disparity`` (float32, NaN where no estimate) by a plane per segment.

    A segment's plane is trusted when its estimates cover at least ``min_support`` of its
    pixels and at least ``min_ratio`` of them lie within ``inlier`` of the plane. Its
    ``replaceable`` pixels (all by default) without an estimate, or with one more than
    ``outlier`` from the plane, take the plane's value limited to ``low..high``.
    ``usable``: the estimates the planes are fitted to (every finite one by default).
    """
    finite = np.isfinite(disparity)
    usable = finite if usable is None else (usable & finite)
    replaceable = np.ones_like(finite) if replaceable is None else replaceable
    labels = superpixels(colour, step, compactness, slic_iterations)
    planes, support = fit_planes(disparity, usable, labels, step, iterations, inlier, stop)
    used, inliers, size = support[:, 0], support[:, 1], support[:, 2]
    trusted = (used >= 3) & (used >= min_support * size) & (inliers >= min_ratio * np.maximum(used, 1))
    out = np.empty_like(disparity)
    _kernels.apply_planes(
        disparity, np.ascontiguousarray(replaceable), labels, planes, trusted, float(outlier),
        float(low), float(high), out,
    )  # fmt: skip
    return out
