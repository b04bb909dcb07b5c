"""Robust planes per segment of the left image: a refinement of ``sgm``'s map.

Large weakly textured or slanted surfaces (a wall, a table, a floor) are where a
semi-global matcher leaves streaks and holes, but there the true disparity is close to a
plane over any small patch of one colour. :func:`segment_planes` cuts the left image into
superpixels (SLIC, :func:`superpixels`), fits a plane ``d = a x + b y + c`` to each
segment's trusted estimates by RANSAC and least squares (:func:`fit_planes`), and where a
segment's plane explains most of its estimates, gives the plane's value to its pixels
without an estimate and to those whose estimate is far from it.
"""

from dataclasses import dataclass, replace

import numba as nb
import numpy as np

from dcstereo.refine import _planes as _kernels
from dcstereo.refine.postfilter import right_image_bounds
from dcstereo.result import FLAG_BORDER, FLAG_FILLED, FLAG_OCCLUDED, DisparityResult


@dataclass(frozen=True)
class PlaneParams:
    """Parameters of :func:`refine_planes`.

    Defaults measured on the development scenes (``scripts/eval_refine.py``).

    ``steps``: one pass of planes each, over superpixels of about that many pixels a side
    (:func:`superpixels`, with ``compactness`` and ``slic_iterations``), coarse to fine:
    each pass fits its planes to the map the pass before left (the holes it filled among
    the estimates); ``slic_scale``: the superpixels cut on the image shrunk that many
    times (:func:`coarse_superpixels`, for speed), one for every pass or one per pass;
    None: ``step // 8`` (at least 1) for each pass, superpixels of about 8 blocks a side
    (6, 4 and 2 for the default steps);
    ``iterations``, ``inlier``, ``stop``, ``max_scored``: the RANSAC of each segment
    (:func:`fit_planes`); ``fit_lattice``: the planes fitted to, and judged by, the
    estimates of every ``fit_lattice``-th row and column only;
    ``min_support``, ``min_ratio``: when a plane is trusted; ``outlier``: how far from it
    an estimate is replaced; ``fit_margin``: the least confidence margin of an estimate
    the planes are fitted to; ``replace_margin``: estimates whose margin is below it may
    be replaced (those above are kept whatever the plane says).
    """

    steps: tuple[int, ...] = (48, 32, 16)
    compactness: float = 10.0
    slic_iterations: int = 3
    slic_scale: int | tuple[int, ...] | None = None
    iterations: int = 100
    max_scored: int = 128
    fit_lattice: int = 2
    inlier: float = 1.5
    stop: float = 0.9
    min_support: float = 0.3
    min_ratio: float = 0.6
    outlier: float = 2.0
    fit_margin: float = 0.05
    replace_margin: float = 0.15

    def __post_init__(self):
        if (
            isinstance(self.max_scored, bool)
            or not isinstance(self.max_scored, int)
            or self.max_scored < 3
        ):
            raise ValueError(
                f"max_scored must be an integer of at least 3, got {self.max_scored!r}"
            )
        for name in ("slic_iterations", "iterations", "fit_lattice"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        steps = self.steps
        if (
            not isinstance(steps, tuple)
            or not steps
            or not all(isinstance(f, int) and not isinstance(f, bool) and f >= 2 for f in steps)
        ):
            raise ValueError(f"steps must be a non-empty tuple of integers from 2, got {steps!r}")
        scale = self.slic_scale
        scales = scale if isinstance(scale, tuple) else (scale,)
        if scale is not None and (
            not all(isinstance(f, int) and not isinstance(f, bool) and f >= 1 for f in scales)
            or (isinstance(scale, tuple) and len(scales) != len(steps))
        ):
            raise ValueError(
                "slic_scale must be None, a positive integer or one per step, got "
                f"{scale!r} for steps {steps!r}"
            )
        for name in ("compactness", "inlier", "outlier"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not np.isfinite(value) or value <= 0:
                raise ValueError(f"{name} must be a positive number, got {value!r}")
        for name in ("stop", "min_support", "min_ratio", "fit_margin", "replace_margin"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not 0 <= value <= 1:
                raise ValueError(f"{name} must be a number from 0 to 1, got {value!r}")


def pass_scales(params: PlaneParams) -> tuple[int, ...]:
    """Return the shrink factor of each pass of ``params.steps`` (``slic_scale`` resolved)."""
    scale = params.slic_scale
    if scale is None:
        return tuple(max(1, step // 8) for step in params.steps)
    return scale if isinstance(scale, tuple) else (scale,) * len(params.steps)


def superpixels(colour: np.ndarray, step: int = 16, compactness: float = 20.0,
                iterations: int = 5) -> np.ndarray:  # fmt: skip
    """SLIC superpixels of ``colour`` (``(C, H, W)``, gray levels): ``(H, W)`` int32 labels.

    Labels are the cells of a grid of about ``step`` pixels (``gy * nx + gx``).
    """
    colour = np.ascontiguousarray(colour, dtype=np.float64)
    labels = np.empty(colour.shape[1:], dtype=np.int32)
    _kernels.slic(
        colour, int(step), float(compactness), int(iterations), labels, nb.get_num_threads()
    )
    return labels


def shrunk(colour: np.ndarray, scale: int) -> np.ndarray:
    """``colour`` (``(C, H, W)``) with each ``scale x scale`` block averaged, float64.

    A block cut by the edge: the mean of its pixels. ``scale`` 1: ``colour`` as float64.
    """
    if scale == 1:
        return np.ascontiguousarray(colour, dtype=np.float64)
    height, width = colour.shape[1:]
    small = np.empty((colour.shape[0], -(-height // scale), -(-width // scale)), np.float64)
    _kernels.shrink(np.ascontiguousarray(colour), scale, small)
    return small


def coarse_superpixels(colour: np.ndarray, step: int, compactness: float, iterations: int,
                       scale: int, *, small: np.ndarray | None = None,
                       out: np.ndarray | None = None):  # fmt: skip
    """:func:`superpixels` of ``colour`` shrunk ``scale`` times: ``(labels, nx, ny)``.

    Each ``scale x scale`` block of pixels averaged (a block cut by the edge: its pixels),
    cut into superpixels of about ``step / scale`` blocks a side, each pixel labelled as its
    block: ``scale**2`` times less work, for edges a block coarse. ``scale`` 1: the image
    itself. ``nx, ny``: the labels' grid. ``small``: ``shrunk(colour, scale)``, when the
    caller has it already; ``out``: an ``(H, W)`` int32 array for the labels (scale above 1).
    """
    height, width = colour.shape[1:]
    if small is None:
        small = shrunk(colour, scale)
    if scale == 1:
        ny, nx = _kernels.grid_shape(height, width, step)
        return superpixels(small, step, compactness, iterations), nx, ny
    rows, cols = small.shape[1:]
    coarse_step = max(2, round(step / scale))
    labels = superpixels(small, coarse_step, compactness, iterations)
    ny, nx = _kernels.grid_shape(rows, cols, coarse_step)
    full = np.empty((height, width), dtype=np.int32) if out is None else out
    _kernels.expand(labels, scale, full)
    return full, nx, ny


def fit_planes(disparity: np.ndarray, usable: np.ndarray, labels: np.ndarray, nx: int,
               ny: int, iterations: int = 200, inlier: float = 1.0,
               stop: float = 0.9, max_scored: int = 2**30, *,
               wanted: np.ndarray | None = None, min_support: float = 0.0,
               lattice: int = 1, scratch=None):  # fmt: skip
    """Fit a plane to each segment's ``usable`` estimates; return ``(planes, support)``.

    Each RANSAC draw is scored on about ``max_scored`` of a segment's estimates (every
    ``n // max_scored``-th), the refit on all of them.

    ``labels``: ``gy * nx + gx`` on a grid of ``ny x nx`` segments. ``planes``: ``(n, 3)``
    float64, ``(a, b, c)`` of ``d = a x + b y + c``; ``support``: ``(n, 3)`` int64,
    (estimates used, inliers within ``inlier`` px, pixels of the segment). Only the
    segments with a ``wanted`` pixel (every pixel by default) whose estimates cover at least
    ``min_support`` of their pixels are fitted; the others get no plane and no inliers.
    ``lattice``: only every ``lattice``-th row and column's estimates and pixels count
    (the used, the inliers, the pixels; a segment is fitted when any of its pixels is
    wanted). ``scratch``: :func:`point_buffers` of the image's size, when the caller reuses
    them.
    """
    n = ny * nx
    planes = np.zeros((n, 3), dtype=np.float64)
    support = np.zeros((n, 3), dtype=np.int64)
    if wanted is None:
        wanted = np.ones(labels.shape, dtype=bool)
    disparity = np.ascontiguousarray(disparity)
    if disparity.dtype not in (np.float32, np.float64):
        disparity = disparity.astype(np.float64)
    if scratch is None:
        scratch = point_buffers(disparity.shape)
    _kernels.fit_planes(
        disparity, np.ascontiguousarray(usable),
        np.ascontiguousarray(wanted), np.ascontiguousarray(labels), n, int(iterations),
        float(inlier), float(stop), int(max_scored), float(min_support), int(lattice),
        *scratch, planes, support, nb.get_num_threads(),
    )  # fmt: skip
    return planes, support


def point_buffers(shape):
    """Return the buffers :func:`fit_planes` gathers estimates in, for a map of ``shape``.

    Columns and rows (int32) and disparities (float64), one element per pixel.
    """
    size = int(np.prod(shape))
    return np.empty(size, np.int32), np.empty(size, np.int32), np.empty(size, np.float64)


def _plane_pass(disparity, labels, nx, ny, usable, replaceable, low, high, iterations,
                inlier, outlier, min_ratio, min_support, stop, max_scored=2**30,
                scratch=None, into=None, lattice=1):  # fmt: skip
    """One pass: fit each segment's plane, give its value where the plane is trusted.

    Only the segments with a ``replaceable`` pixel and enough support are fitted: the
    others could change nothing. ``into``: the array the new map is written to (a new one
    by default; ``disparity`` itself may be given: each pixel reads only its own value).
    """
    planes, support = fit_planes(
        disparity, usable, labels, nx, ny, iterations, inlier, stop, max_scored,
        wanted=replaceable, min_support=min_support, lattice=lattice, scratch=scratch,
    )  # fmt: skip
    used, inliers, size = support[:, 0], support[:, 1], support[:, 2]
    trusted = (used >= 3) & (used >= min_support * size)
    trusted &= inliers >= min_ratio * np.maximum(used, 1)
    out = np.empty_like(disparity) if into is None else into
    _kernels.apply_planes(
        disparity, np.ascontiguousarray(replaceable), labels, planes, trusted, float(outlier),
        float(low), float(high), out,
    )  # fmt: skip
    return out


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
    ny, nx = _kernels.grid_shape(disparity.shape[0], disparity.shape[1], int(step))
    return _plane_pass(disparity, labels, nx, ny, usable, replaceable, low, high, iterations,
                       inlier, outlier, min_ratio, min_support, stop)  # fmt: skip


def refine_planes(
    result: DisparityResult,
    colour: np.ndarray,
    margin: np.ndarray,
    params: PlaneParams = PlaneParams(),
) -> DisparityResult:
    """``sgm``'s stage: a plane per segment for its holes and its unsure estimates.

    ``result``: ``sgm``'s map after the left-right check, not filled; ``colour``: the left
    image's channels ``(C, H, W)``; ``margin``: ``sgm``'s confidence margin per pixel.
    The planes are fitted to the estimates with a margin of at least ``fit_margin``; the
    mismatched pixels (not the occluded or border ones: the background fill's) and
    the estimates with a margin under ``replace_margin`` may take their plane's value
    (:func:`segment_planes`), limited to the searched range. A hole filled so keeps its
    reason flag and gains :data:`~dcstereo.result.FLAG_FILLED`; an estimate whose plane's
    value points past the right image (``x - d`` beyond -0.5 .. ``width - 0.5``: a pixel
    at its border that the plane carries on, with no match in the right view) gains
    :data:`~dcstereo.result.FLAG_BORDER` and ``FLAG_FILLED``: its value is the plane's,
    not an estimate of the matcher's.
    """
    d = result.disparity
    free = (result.flags & (FLAG_OCCLUDED | FLAG_BORDER)) == 0  # not the background fill's
    unsure = margin < params.replace_margin
    sure = margin >= params.fit_margin
    scales = pass_scales(params)
    small = {scale: shrunk(colour, scale) for scale in set(scales)}  # one per scale
    # the buffers every pass reuses (fresh arrays of this size cost their page faults)
    out = np.array(d, dtype=np.float32)  # the map, each pass writing its own in place
    scratch = point_buffers(d.shape)
    labels_full = np.empty(d.shape, dtype=np.int32)
    holes, usable, replaceable = (np.empty(d.shape, dtype=bool) for _ in range(3))
    for step, scale in zip(params.steps, scales, strict=True):
        labels, nx, ny = coarse_superpixels(
            colour, step, params.compactness, params.slic_iterations, scale,
            small=small[scale], out=labels_full,
        )  # fmt: skip
        np.isnan(out, out=holes)
        np.greater(sure, holes, out=usable)  # sure and not a hole
        np.logical_or(holes, unsure, out=replaceable)
        replaceable &= free
        _plane_pass(
            out, labels, nx, ny, usable, replaceable,
            result.params.min_disparity, result.params.max_disparity, params.iterations,
            params.inlier, params.outlier, params.min_ratio, params.min_support, params.stop,
            params.max_scored, scratch, out, params.fit_lattice,
        )  # fmt: skip
    filled = np.isnan(d) & np.isfinite(out)
    # an estimate whose plane's value points past the right image (a left border's pixel
    # the plane carries on) has no match there: it is a border pixel, filled by its plane
    least, largest = right_image_bounds(d.shape[1])
    outside = np.isfinite(d) & (out != d) & ((out < least) | (out > largest))
    flags = result.flags | (filled.view(np.uint8) * np.uint8(FLAG_FILLED))
    flags |= outside.view(np.uint8) * np.uint8(FLAG_BORDER | FLAG_FILLED)
    return replace(result, disparity=out, flags=flags)
