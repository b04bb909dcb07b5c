"""``sgm``: census costs, semi-global aggregation, a left-right check and an edge-aware fill.

The accurate pipeline of :func:`dcstereo.match` (its default method). Each stage is a
function of arrays with its parameters in :class:`~dcstereo.params.MatchParams`:

1. costs (the kernels of ``dcstereo.kernels.census``): the census transform of each view's intensity
   over ``census_window``, compared by Hamming distance, plus (``cost="census-ad"``) the
   absolute difference of the colours, truncated at ``ad_truncation`` gray levels; each
   averaged over a ``window x window`` box;
2. aggregation (the kernels of ``dcstereo.kernels.sgm``): semi-global matching along ``paths`` 1-D
   paths (Hirschmueller 2008) with penalties ``p1`` for a step of one pixel of disparity
   and ``p2`` for a larger jump, ``p2`` lowered across intensity edges
   (``p2_gradient``);
3. the disparity of least aggregated cost (winner-take-all), refined to a fraction of a
   pixel by a fit through its neighbours (``subpixel``);
4. a left-right check: a left pixel whose right pixel prefers another disparity loses its
   estimate, flagged occluded (:data:`~dcstereo.result.FLAG_OCCLUDED`) or mismatched
   (:data:`~dcstereo.result.FLAG_MISMATCH`);
5. with ``fill`` (on by default): occluded pixels take the background (the smaller
   neighbouring disparity of their row), mismatched ones the estimate of the nearest
   pixel of the most similar colour along eight directions
   (:mod:`dcstereo.consistency`);
6. the median post-filter (``median``, by :func:`dcstereo.match`).

Memory: the volumes of a strip of rows (costs and two sums of paths, 6 bytes per pixel and
disparity, the disparities rounded up to a multiple of 16). Images whose volumes would
pass :data:`VOLUME_BYTES` run in strips of rows, each with :data:`STRIP_MARGIN` rows of
context above and below; paths then start at the strip's edge, so such a result differs
(slightly, near the strips' seams) from the whole-image one. The volumes are kept from one
call to the next in each thread (fresh volumes past the allocator's reuse bound come from
the system zeroed page by page, a sixth of a run on a 720 x 496 x 73 pair);
:func:`release_workspace` frees them.
"""

import threading

import numpy as np

from .consistency import fill_with_colour
from .cross_support import cross_aggregate
from .kernels import census as census_kernels
from .kernels import sgm as sgm_kernels
from .kernels.census_sparse import census_sparse
from .kernels.sgm_simd import HIGH, LANES
from .params import MatchParams
from .result import FLAG_MISMATCH, DisparityResult
from .signal import SIGNAL_STEPS, padded_signal

assert FLAG_MISMATCH == sgm_kernels.FLAG_MISMATCH

#: The most memory (bytes) the volumes of one strip take; larger images run in strips.
VOLUME_BYTES = 768 * 2**20

#: Rows of context above and below each strip of a large image.
STRIP_MARGIN = 32

#: The kernels' costs per cost unit: thirds, so that the sum of three channels' absolute
#: differences is their mean, exactly (``kernels.census.pixel_cost_row``).
UNITS = 3

#: The census term's largest value: a census of ``n`` bits costs ``round(CENSUS_SPAN / n)``
#: a differing bit, so the term spans about the same range for every window.
CENSUS_SPAN = 96

_SUBPIXEL = {
    None: sgm_kernels.SUBPIXEL_NONE,
    "parabola": sgm_kernels.SUBPIXEL_PARABOLA,
    "equiangular": sgm_kernels.SUBPIXEL_EQUIANGULAR,
}


def census_bit_cost(window: tuple[int, int]) -> int:
    """Cost of one differing census bit for a ``(rows, cols)`` window."""
    bits = window[0] * window[1] - 1
    return max(1, round(CENSUS_SPAN / bits))


def largest_pixel_cost(params: MatchParams) -> int:
    """Return the largest per-pixel cost of ``params``' cost (before the box average)."""
    rows, cols = params.census_window
    ad = params.ad_truncation if params.cost == "census-ad" else 0
    return census_bit_cost(params.census_window) * (rows * cols - 1) + int(ad)


def check_sgm_bounds(params: MatchParams) -> np.float32:
    """Return the box average's reciprocal; raise ``ValueError`` past the kernels' 16 bits.

    The kernels count in :data:`UNITS` per cost unit (``pixel_cost_row``); the reciprocal is
    ``kernels.census.box_reciprocal``'s for the largest box sum of those units.
    """
    largest = largest_pixel_cost(params)
    reciprocal = census_kernels.box_reciprocal(params.window, UNITS * largest * params.window**2)
    if params.paths * UNITS * (largest + params.p2) >= HIGH:
        most = HIGH // (params.paths * UNITS) - largest - 1
        raise ValueError(
            f"p2={params.p2} is too large for {params.paths} paths of costs up to {largest}: "
            f"the sums must fit 16 bits (p2 at most {most})"
        )
    return reciprocal


def colour_channels(left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the two views' channels on the 0..255 scale as ``(C, H, W)`` int16, rounded.

    Colour views give their three channels (an alpha channel is ignored); where either is
    gray, both give their intensity (luma), so the two always have as many channels.
    """

    def scaled(image):
        image = np.asarray(image)
        if image.dtype == np.uint8:
            return image
        if image.dtype == np.uint16:
            return image.astype(np.float64) / 257.0
        return image.astype(np.float64) * 255.0

    colour = left.ndim == 3 and right.ndim == 3 and min(left.shape[2], right.shape[2]) >= 3
    out = []
    for image in (left, right):
        if colour:
            channels = np.moveaxis(scaled(image[:, :, :3]), 2, 0)
        else:
            channels = padded_signal(image, 0)[np.newaxis] / float(SIGNAL_STEPS)
        if channels.dtype != np.uint8:
            channels = np.clip(np.rint(channels), 0, 255)
        out.append(np.ascontiguousarray(channels, dtype=np.int16))
    return out[0], out[1]


def p2_table(params: MatchParams) -> np.ndarray:
    """``P2`` by the absolute intensity difference of a path's two pixels (1/16 gray levels).

    ``p2 / (1 + g / p2_gradient)`` for a difference of ``g`` gray levels, truncated, and
    never below ``p1 + 1``; ``p2_gradient`` 0 keeps ``p2`` everywhere.
    """
    steps = np.arange(255 * SIGNAL_STEPS + 1, dtype=np.float64) / SIGNAL_STEPS
    if params.p2_gradient > 0:
        values = params.p2 / (1.0 + steps / params.p2_gradient)
    else:
        values = np.full_like(steps, float(params.p2))
    return np.maximum(np.floor(values), params.p1 + 1).astype(np.int64)


def _reversed_right(array: np.ndarray, before: int, after: int) -> np.ndarray:
    """Return the right view's ``array`` (``(..., H, W)``) as the cost kernel reads it.

    Padded along its last axis by ``before`` and ``after`` repeated edge columns, then
    reversed.
    """
    widths = [(0, 0)] * (array.ndim - 1) + [(before, after)]
    return np.ascontiguousarray(np.pad(array, widths, mode="edge")[..., ::-1])


_WORKSPACE = threading.local()


def _volumes(size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return three int16 volumes of ``size`` values: the costs and the two sums of paths.

    Kept from call to call in each thread (the largest asked for so far, at most
    :data:`VOLUME_BYTES` together): fresh volumes larger than the allocator's reuse bound
    (32 MiB, ``dcstereo._memory``) come from the system zeroed page by page, which cost a
    sixth of the run on a 720 x 496 x 73 pair. :func:`release_workspace` frees them.
    """
    held = getattr(_WORKSPACE, "volumes", None)
    if held is None or held[0].size < size:
        held = tuple(np.empty(size, dtype=np.int16) for _ in range(3))
        _WORKSPACE.volumes = held
    return tuple(volume[:size] for volume in held)


def release_workspace() -> None:
    """Free the volumes this thread keeps between ``sgm`` runs.

    The costs and the sums of paths, kept to save the zeroing of fresh pages (see the
    module's text).
    """
    _WORKSPACE.volumes = None


def _census(signal: np.ndarray, rows: int, cols: int, out: np.ndarray, step: int = 1) -> None:
    """Write the census codes of ``signal`` (``padded_signal(image, 0)``) into ``out``.

    ``step`` > 1: the sparse census, its samples ``step`` pixels apart.
    """
    ry, rx = step * (rows // 2), step * (cols // 2)
    padded = np.pad(signal, ((ry, ry), (rx, rx)), mode="edge")
    if step == 1:
        census_kernels.census_transform(padded, rows, cols, out)
    else:
        census_sparse(padded, rows, cols, step, out)


def match_sgm(left: np.ndarray, right: np.ndarray, params: MatchParams) -> DisparityResult:
    """Run the ``sgm`` pipeline up to the fill (the median is :func:`dcstereo.match`'s)."""
    return _run(left, right, params, False)[0]


def sgm_confidence(left: np.ndarray, right: np.ndarray, params: MatchParams) -> np.ndarray:
    """Return the confidence of each pixel's ``sgm`` choice: its margin over the best rival.

    ``(rival - best) / rival`` of the aggregated costs, ``rival`` the least of the
    disparities two or more pixels from the chosen one: in ``[0, 1]``, near 0 where another
    disparity is about as good. The run is made again with ``params`` (the same choices).
    """
    return _run(left, right, params, True)[1]


def _run(left, right, params, want_confidence):
    """Run the pipeline; return the result (filled when ``params.fill``) and the confidence."""
    height, width = left.shape[:2]
    dmin, ndisp = params.min_disparity, params.num_disparities
    lanes = -(-ndisp // LANES) * LANES
    rows, cols = params.census_window
    kind = np.uint32 if rows * cols - 1 <= 32 else np.uint64
    codes_l = np.empty((height, width), dtype=kind)
    codes_r = np.empty((height, width), dtype=kind)
    luma_l = padded_signal(left, 0)
    _census(luma_l, rows, cols, codes_l, params.census_step)
    _census(padded_signal(right, 0), rows, cols, codes_r, params.census_step)
    colour_l, colour_r = colour_channels(left, right)
    guide = colour_l if params.aggregation is not None else None
    guide_r = colour_r if params.aggregation == "cross-both" else None
    if params.cost == "census":
        colour_l = colour_l[:1, :1, :1]  # unread (ad_max 0); one unit a cost unit
        colour_r = colour_r[:1, :1, :1]
    pad = max(0, params.max_disparity)
    after = max(0, -dmin)
    codes_r = _reversed_right(codes_r, pad, after)
    if params.cost == "census-ad":
        colour_r = _reversed_right(colour_r, pad, after)
    reciprocal = check_sgm_bounds(params)
    largest = UNITS * largest_pixel_cost(params)
    pad_cost = largest + UNITS * params.p2 + 1
    table = UNITS * p2_table(params)
    p1 = UNITS * params.p1
    ad_max = params.ad_truncation if params.cost == "census-ad" else 0
    bit_cost = census_bit_cost(params.census_window)
    diagonals = params.paths == 8

    disparity = np.empty((height, width), dtype=np.float32)
    flags = np.empty((height, width), dtype=np.uint8)
    margin = np.empty((height, width if want_confidence else 0), dtype=np.float32)
    per_row = width * lanes * 2 * 3
    strip = max(1, VOLUME_BYTES // per_row - 2 * STRIP_MARGIN)
    for s0 in range(0, height, strip):
        s1 = min(height, s0 + strip)
        m0, m1 = (
            (0, height)
            if strip >= height
            else (max(0, s0 - STRIP_MARGIN), min(height, s1 + STRIP_MARGIN))
        )
        n = m1 - m0
        volume, down, up = _volumes(n * width * lanes)
        volume = volume.reshape(n, width, lanes)
        census_kernels.cost_volume(
            codes_l, codes_r, colour_l, colour_r, dmin, ndisp, bit_cost, ad_max, params.window,
            reciprocal, pad_cost, m0, volume,
        )  # fmt: skip
        if params.aggregation in ("cross", "cross-both"):
            cross_aggregate(
                volume, guide[:, m0:m1], ndisp, limit=params.cross_limit, tau=params.cross_tau,
                iterations=params.cross_iterations,
                colour_r=None if guide_r is None else guide_r[:, m0:m1], dmin=dmin,
            )  # fmt: skip
        cost = volume.reshape(-1)
        luma = np.ascontiguousarray(luma_l[m0:m1])
        sgm_kernels.vertical_passes(cost, luma, p1, table, diagonals, down, up)
        sgm_kernels.final_pass(
            cost, luma, down, up, s0 - m0, s1 - m0, dmin, ndisp, p1, table,
            _SUBPIXEL[params.subpixel], -1 if params.lr_tolerance is None else params.lr_tolerance,
            disparity[s0:s1], flags[s0:s1], margin[s0:s1],
        )  # fmt: skip
    result = DisparityResult(disparity, flags, params, np.full(height, np.nan))
    if params.fill:
        if colour_l.shape[1:] != (height, width):  # cost="census" keeps no colours
            colour_l, _ = colour_channels(left, left)
        result = fill_with_colour(result, colour_l)
    return result, margin
