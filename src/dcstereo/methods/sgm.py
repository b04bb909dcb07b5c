"""``sgm``: census costs, semi-global aggregation, a left-right check and an edge-aware fill.

The accurate pipeline of :func:`dcstereo.match` (its default method). Each stage is a
function of arrays with its parameters in :class:`~dcstereo.params.MatchParams`:

1. costs (the kernels of ``dcstereo.costs.census``): the census transform of each view's intensity
   over ``census_window``, compared by Hamming distance, plus (``cost="census-ad"``) the
   absolute difference of the colours, truncated at ``ad_truncation`` gray levels; each
   averaged over a ``window x window`` box;
2. aggregation (the kernels of ``dcstereo.aggregate.sgm``): semi-global matching along ``paths`` 1-D
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
   (:mod:`dcstereo.refine.consistency`);
6. the median post-filter (``median``, by :func:`dcstereo.match`).

With ``census_smoothing`` (a sigma in pixels; 0, none, by default), in 1: each view's
intensity smoothed by a Gaussian before the census transform (:mod:`dcstereo.costs.smoothing`).

With ``photometric="matched"`` (off by default), before 1: the right view's colours mapped
onto the left's through the colours of the pixels a coarse pass matched
(:mod:`dcstereo.costs.photometric`).

With ``row_alignment="estimated"`` (off by default), before 1: the right view's rows moved
onto the left's by the vertical offsets measured around the coarse pass's matches, where
the pair is not quite rectified (:mod:`dcstereo.costs.row_offsets`).

With ``planes`` (off by default), between 4 and 5: a robust plane per superpixel of the left
image for the mismatches and the unsure estimates (:func:`dcstereo.refine.planes.refine_planes`).

With ``edges="support-weights"`` (off by default), after 6: the pixels near the map's depth
edges decided again between their value and the farther ones past the jumps around them,
by adaptive support weights over the views as the costs saw them
(:mod:`dcstereo.refine.edges`).

Memory of a call on a ``W x H`` pair searching ``D`` disparities (``Dp``: ``D`` rounded up to
a multiple of 16): the volumes (the costs and two sums of paths, int16) of one tile,
``6 * tile pixels * Dp`` bytes, at most :data:`VOLUME_BYTES` (768 MiB): the whole image when
``6 * W * H * Dp`` fits, otherwise a grid of tiles of rows and columns (:func:`tiles`), each
with :data:`STRIP_MARGIN` rows and columns of context on each side, which the paths cross
from the tile's edge, so that such a result differs (slightly, near the cuts) from the
whole-image one; about 45 bytes a pixel of images, codes and choices; and each thread's
path buffers, about ``16 * tile width * Dp`` bytes. When the call ends its volumes go back
to one pool for the whole process: kept for the next call (at most :data:`KEPT_BYTES`
together, the largest first; fresh volumes past the allocator's reuse bound come from the
system zeroed page by page, a sixth of a run on a 720 x 496 x 73 pair) and freed
:data:`IDLE_SECONDS` (10 s) after the last call ends, or by :func:`release_workspace`. Calls
from several threads at once hold at most :data:`WORKSPACE_BYTES` (1.5 GiB) of volumes
together, those kept included: a call that would pass it waits for another to end.

Threads: numba's thread count (``numba.set_num_threads``, or ``NUMBA_NUM_THREADS`` before
numba starts; all cores by default). The parallel loops hand out small tasks (the two vertical
passes, or from 6 threads bands of each of their path directions; a pair of rows; a row) to
whichever thread is free, so a thread that waits for a core (other work on the machine)
holds back one task.
"""

import threading
import time
from dataclasses import dataclass

import numba
import numpy as np

from dcstereo._threads import free_threads, threads_with_cores  # noqa: F401 (free_threads: its docs)
from dcstereo._vector.sgm import HIGH, LANES
from dcstereo.aggregate import sgm as sgm_kernels
from dcstereo.aggregate.cross import cross_aggregate
from dcstereo.costs import census as census_kernels
from dcstereo.costs import photometric, row_offsets
from dcstereo.costs.census_sparse import census_sparse
from dcstereo.costs.smoothing import smooth_signal
from dcstereo.methods._pipeline import (
    FILL,
    MEDIAN,
    Method,
    MethodParams,
    Stage,
    core,
    option,
    run_shared,
)
from dcstereo.params import MatchParams
from dcstereo.refine.consistency import fill_with_colour
from dcstereo.refine.edges import refine_edges
from dcstereo.refine.planes import refine_planes
from dcstereo.result import DisparityResult
from dcstereo.signal import SIGNAL_STEPS, check_pair, colour_channels, padded_signal

#: Rows (and columns) of context on each side of a tile of a large image.
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
    reversed, in one pass (``census.reversed_padded_rows``; ``np.pad`` then a reversed
    copy took 5 ms of a 94 ms call on Piano).
    """
    rows = np.ascontiguousarray(array).reshape(-1, array.shape[-1])
    out = census_kernels.reversed_padded_rows(rows, before, after)
    return out.reshape(*array.shape[:-1], out.shape[-1])


class _VolumePool:
    """The volumes of all ``sgm`` calls of the process, in use and kept, within one bound.

    A call takes a set of three int16 volumes (the costs and the two sums of paths) with
    :meth:`take` and gives it back with :meth:`give`. Sets given back are kept for the next
    calls (fresh volumes larger than the allocator's reuse bound, 32 MiB, come from the
    system zeroed page by page, a sixth of a run on a 720 x 496 x 73 pair), at most
    :data:`KEPT_BYTES` of them, the largest first, and freed :data:`IDLE_SECONDS` after the
    last call ends. Sets in use and kept together never pass :data:`WORKSPACE_BYTES`: a
    call that would pass it frees kept sets, then waits for other calls to give theirs back
    (a call alone always runs). ``peak`` is the most bytes held at once since the last
    :meth:`release`; ``in_use`` and ``kept`` the bytes now.
    """

    def __init__(self):
        self._lock = threading.Condition()
        self._free = []  # sets of three volumes of one size, the largest last
        self.in_use = 0
        self.kept = 0
        self.peak = 0
        self._given = 0.0  # time.monotonic() of the last set given back
        self._timer = None

    def take(self, size):
        """Return three int16 volumes of ``size`` values (flat), and the set to give back."""
        need = 3 * 2 * size
        with self._lock:
            while True:
                fits = [i for i, held in enumerate(self._free) if held[0].size >= size]
                if fits:  # the smallest kept set that holds the call
                    held = self._free.pop(fits[0])
                    self.kept -= 3 * held[0].nbytes
                    self.in_use += 3 * held[0].nbytes
                    return tuple(volume[:size] for volume in held), held
                if self.in_use + self.kept + need <= WORKSPACE_BYTES or not (
                    self.in_use or self._free
                ):
                    break
                if self._free:  # too small for this call: freed, the smallest first
                    self.kept -= 3 * self._free.pop(0)[0].nbytes
                else:
                    self._lock.wait()
            self.in_use += need
            self.peak = max(self.peak, self.in_use + self.kept)
        held = tuple(np.empty(size, dtype=np.int16) for _ in range(3))
        return held, held

    def give(self, held):
        """Take back a set of :meth:`take`; keep it (within :data:`KEPT_BYTES`) or free it."""
        with self._lock:
            self.in_use -= 3 * held[0].nbytes
            self._free.append(held)
            self._free.sort(key=lambda volumes: volumes[0].size)
            self.kept += 3 * held[0].nbytes
            while self.kept > KEPT_BYTES:
                self.kept -= 3 * self._free.pop(0)[0].nbytes
            self._lock.notify_all()
            self._given = time.monotonic()
            if self._free and self._timer is None and IDLE_SECONDS is not None:
                self._arm(IDLE_SECONDS)

    def _arm(self, seconds):
        self._timer = threading.Timer(seconds, self._idle)
        self._timer.daemon = True
        self._timer.start()

    def _idle(self):
        with self._lock:
            self._timer = None
            idle = time.monotonic() - self._given
            if not self.in_use and idle >= IDLE_SECONDS:
                self._drop()
            elif self._free:  # a call runs, or one ended since: wait from the last end
                self._arm(IDLE_SECONDS - idle if not self.in_use else IDLE_SECONDS)

    def _drop(self):
        self._free = []
        self.kept = 0

    def release(self):
        """Free the kept sets now (sets in use are freed when their calls end)."""
        with self._lock:
            self._drop()
            self.peak = self.in_use


#: The most memory (bytes) one call's volumes take: larger images run in tiles.
VOLUME_BYTES = 768 * 2**20

#: The most memory (bytes) the volumes of all calls take at once, those kept included.
WORKSPACE_BYTES = 2 * VOLUME_BYTES

#: The most memory (bytes) of volumes kept between calls, for the whole process.
KEPT_BYTES = VOLUME_BYTES

#: Seconds after the last call ends that the kept volumes are freed (None: kept until
#: :func:`release_workspace`).
IDLE_SECONDS = 10.0

_POOL = _VolumePool()


def release_workspace() -> None:
    """Free the volumes ``sgm`` keeps between calls (see the module's text).

    The costs and the sums of paths, kept to save the zeroing of fresh pages; volumes of
    calls still running are freed when they end.
    """
    _POOL.release()


def workspace_bytes() -> dict:
    """Return the bytes of volumes in use, kept, and the most held at once (``peak``).

    ``peak`` counts from the last :func:`release_workspace`.
    """
    with _POOL._lock:
        return {"in_use": _POOL.in_use, "kept": _POOL.kept, "peak": _POOL.peak}


def tiles(height: int, width: int, lanes: int) -> list[tuple[tuple[int, ...], tuple[int, ...]]]:
    """Return the tiles of an image whose volumes pass :data:`VOLUME_BYTES`.

    Each tile is ``((m0, s0, s1, m1), (c0, k0, k1, c1))``: rows ``m0..m1 - 1`` and columns
    ``c0..c1 - 1`` are computed, of which rows ``s0..s1 - 1`` and columns ``k0..k1 - 1`` are
    kept; the others are :data:`STRIP_MARGIN` rows or columns of context on each side
    within the image. One tile holds the image when its volumes fit; otherwise the grid
    of row strips and column tiles that computes the fewest pixels, each tile's volumes
    within the bound (or within ``(2 * STRIP_MARGIN + 1) ** 2`` pixels, where the bound is
    smaller).
    """
    margin = STRIP_MARGIN
    pixels = max(VOLUME_BYTES // (6 * lanes), (2 * margin + 1) ** 2)
    if height * width <= pixels:
        return [((0, 0, height, height), (0, 0, width, width))]

    def computed(size, parts):  # the most a part computes of ``size`` split in ``parts``
        return min(size, -(-size // parts) + (2 * margin if parts > 1 else 0))

    best = None
    for nrows in range(1, height + 1):
        rows = computed(height, nrows)
        cols = pixels // rows
        if cols >= width:
            ncols = 1
        elif cols > 2 * margin:
            ncols = -(-width // (cols - 2 * margin))
        else:
            continue
        work = nrows * ncols * rows * computed(width, ncols)
        if best is None or work < best[0]:
            best = (work, nrows, ncols)
        if ncols == 1:
            break  # more strips only add margins

    def bounds(size, parts):
        out = []
        for i in range(parts):
            s0, s1 = i * size // parts, (i + 1) * size // parts
            out.append((max(0, s0 - margin), s0, s1, min(size, s1 + margin)))
        return out

    return [(r, c) for r in bounds(height, best[1]) for c in bounds(width, best[2])]


def tile_columns(codes_l, codes_r, colour_l, colour_r, c0, c1, colour):
    """Return the inputs of the cost kernel for left columns ``c0..c1 - 1``.

    ``codes_l`` is ``(2, H, W)`` (``census.code_planes``), ``codes_r`` the right codes as
    the kernel reads them (``_reversed_right``: ``W + pad + after`` columns), ``colour_l``
    and ``colour_r`` the ``(C, H, .)`` colours, cut too where ``colour`` (the census-ad
    cost reads them). The tile's right columns are a slice of the reversed ones: ``W - c1``
    on, ``c1 - c0 + pad + after`` of them. The box average repeats the tile's edge columns,
    so a tile's costs equal the image's but in the ``window // 2`` columns at a cut.
    """
    width = codes_l.shape[-1]
    if (c0, c1) == (0, width):
        return codes_l, codes_r, colour_l, colour_r
    right = slice(width - c1, width - c0 + codes_r.shape[-1] - width)
    tile_l = np.ascontiguousarray(codes_l[..., c0:c1])
    tile_r = np.ascontiguousarray(codes_r[..., right])
    if colour:
        colour_l = np.ascontiguousarray(colour_l[:, :, c0:c1])
        colour_r = np.ascontiguousarray(colour_r[:, :, right])
    return tile_l, tile_r, colour_l, colour_r


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
    """Run the pipeline; return the result (filled when ``params.fill``) and the confidence.

    With the threads that have a core now (:func:`free_threads`), set for the calling
    thread alone and restored at the end.
    """
    with threads_with_cores():
        return _run_threads(left, right, params, want_confidence)


def _coarse_pass(colour_l, colour_r, params):
    """Return the coarse pass's left disparities (``photometric``, ``row_alignment``).

    ``sgm`` with the census alone on the two views'
    :data:`~dcstereo.costs.photometric.COARSE_FACTOR` times smaller box means, over the
    range divided by the factor (rounded outwards), no fill; NaN where its left-right check
    rejected the estimate. None for a pair too small for it.
    """
    factor = photometric.COARSE_FACTOR
    if min(colour_l.shape[1:]) < factor * photometric.MIN_COARSE_SIDE:
        return None
    small_l = photometric.box_down(colour_l, factor)
    small_r = photometric.box_down(colour_r, factor)
    if small_l.shape[2] == 1:  # gray: one channel, the intensity
        small_l, small_r = small_l[:, :, 0], small_r[:, :, 0]
    coarse = MatchParams(
        max_disparity=-(-params.max_disparity // factor),
        min_disparity=params.min_disparity // factor,
        method="sgm",
        cost="census",
        fill=False,
    )
    result, _ = _run_threads(small_l, small_r, coarse, False)
    return result.disparity


def _row_field(luma_l, luma_r, coarse):
    """Return the :class:`~dcstereo.costs.row_offsets.RowField` of a pair and its coarse pass.

    ``luma_l``, ``luma_r``: the views' :func:`~dcstereo.signal.padded_signal` (radius 0).
    """
    return row_offsets.estimate_from(
        luma_l / SIGNAL_STEPS, luma_r / SIGNAL_STEPS, coarse, photometric.COARSE_FACTOR
    )


def _aligned_views(left, right, luma_l, luma_r, colour_l, colour_r, params):
    """Return the right view's intensity and channels after ``row_alignment`` and ``photometric``.

    ``luma_l``, ``luma_r``: the views' :func:`~dcstereo.signal.padded_signal` (radius 0),
    ``colour_l``, ``colour_r`` their :func:`~dcstereo.signal.colour_channels`.

    Both read the coarse pass (:func:`_coarse_pass`). With ``row_alignment="estimated"``,
    the right view is moved onto the left's rows
    (:func:`~dcstereo.costs.row_offsets.moved_view`) by the field the coarse pass gives
    (:func:`~dcstereo.costs.row_offsets.estimate_from`), where
    :meth:`~dcstereo.costs.row_offsets.RowField.to_move` says so; with
    ``photometric="matched"``, the right view's channels are then mapped onto the left's
    (:func:`dcstereo.costs.photometric.align_right`) through the coarse pass of the views
    as they are then (run again when the view moved, so that a band of ``match_tiled``,
    given the moved view, maps its colours alike). A pair too small for the coarse pass
    keeps its right view.
    """
    if params.row_alignment is None and params.photometric is None:
        return luma_r, colour_r
    coarse = _coarse_pass(colour_l, colour_r, params)
    if coarse is None:
        return luma_r, colour_r
    if params.row_alignment == "estimated":
        field = _row_field(luma_l, luma_r, coarse)
        offsets = None if field is None else field.to_move()
        if offsets is not None:
            right = row_offsets.moved_view(right, offsets)
            luma_r = padded_signal(right, 0)
            colour_r = colour_channels(left, right, (luma_l, luma_r))[1]
            if params.photometric == "matched":
                coarse = _coarse_pass(colour_l, colour_r, params)
    if params.photometric == "matched":
        colour_r = photometric.align_right(colour_l, colour_r, coarse, photometric.COARSE_FACTOR)
    return luma_r, colour_r


def _views(left: np.ndarray, right: np.ndarray):
    """Return the pair as ``sgm`` reads it: ``(luma_l, luma_r, colour_l, colour_r)``.

    The views' ``padded_signal(view, 0)`` and their ``colour_channels``, each signal made
    once (a gray pair's channels are rounded from them).
    """
    luma_l, luma_r = padded_signal(left, 0), padded_signal(right, 0)
    return (luma_l, luma_r, *colour_channels(left, right, (luma_l, luma_r)))


def sgm_row_field(
    left: np.ndarray, right: np.ndarray, params: MatchParams
) -> row_offsets.RowField | None:
    """Return how far the right view's rows lie from the left's (a ``RowField``).

    The :class:`~dcstereo.costs.row_offsets.RowField` that ``row_alignment="estimated"``
    measures before it moves the rows (it moves them where
    :meth:`~dcstereo.costs.row_offsets.RowField.to_move` says so), over ``params``'
    disparity range: a check of a rig's rectification. The pair is checked as
    :func:`dcstereo.match` checks it. None for a pair too small for the coarse pass or
    without a patch to measure.
    """
    left, right = check_pair(left, right)
    params.check_image_size(*left.shape[:2])
    with threads_with_cores():
        luma_l, luma_r, colour_l, colour_r = _views(left, right)
        coarse = _coarse_pass(colour_l, colour_r, params)
        if coarse is None:
            return None
        return _row_field(luma_l, luma_r, coarse)


def _run_threads(left, right, params, want_confidence):
    """:func:`_run` at the thread count set."""
    height, width = left.shape[:2]
    dmin, ndisp = params.min_disparity, params.num_disparities
    lanes = -(-ndisp // LANES) * LANES
    rows, cols = params.census_window
    kind = np.uint32 if rows * cols - 1 <= 32 else np.uint64
    codes_l = np.empty((height, width), dtype=kind)
    codes_r = np.empty((height, width), dtype=kind)
    luma_l, luma_r, colour_l, colour_r = _views(left, right)
    luma_r, colour_r = _aligned_views(left, right, luma_l, luma_r, colour_l, colour_r, params)
    shared = run_shared()
    if params.edges is not None and shared is not None:  # for this run's edges stage
        shared[_VIEWS] = (colour_l, colour_r)
    sigma = params.census_smoothing
    _census(smooth_signal(luma_l, sigma), rows, cols, codes_l, params.census_step)
    _census(smooth_signal(luma_r, sigma), rows, cols, codes_r, params.census_step)
    guide = colour_l if params.aggregation is not None else None
    guide_r = colour_r if params.aggregation == "cross-both" else None
    if params.cost == "census":
        colour_l = colour_l[:1, :1, :1]  # unread (ad_max 0); one unit a cost unit
        colour_r = colour_r[:1, :1, :1]
    # right columns for every lane of a pixel (census.cost_span: whole vectors), not only
    # for its disparities
    pad = max(0, params.max_disparity + lanes - ndisp)
    after = max(0, -dmin)
    codes_l = census_kernels.code_planes(codes_l)
    codes_r = _reversed_right(census_kernels.code_planes(codes_r), pad, after)
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

    best = np.empty((height, width), dtype=np.int16)
    value = np.empty((height, width), dtype=np.int16)
    candidate = np.empty((height, width), dtype=np.float32)
    keep_margin = want_confidence or params.planes  # the planes read the margins
    margin = np.empty((height, width if keep_margin else 0), dtype=np.float32)
    threads = numba.get_num_threads()
    plan = tiles(height, width, lanes)
    largest_tile = max((r[3] - r[0]) * (c[3] - c[0]) for r, c in plan)
    volumes, held = _POOL.take(largest_tile * lanes)
    try:
        for (m0, s0, s1, m1), (c0, k0, k1, c1) in plan:
            n, w = m1 - m0, c1 - c0
            tile_l, tile_r, ad_l, ad_r = tile_columns(
                codes_l, codes_r, colour_l, colour_r, c0, c1, params.cost == "census-ad"
            )
            volume, down, up = (v[: n * w * lanes] for v in volumes)
            volume = volume.reshape(n, w, lanes)
            census_kernels.cost_volume(
                tile_l, tile_r, ad_l, ad_r, dmin, ndisp, bit_cost, ad_max, params.window,
                reciprocal, pad_cost, m0, volume, threads,
            )  # fmt: skip
            if params.aggregation in ("cross", "cross-both"):
                # a tile's own columns (near a cut, the right view's beyond it count as
                # outside, as the paths start there)
                cross_aggregate(
                    volume, np.ascontiguousarray(guide[:, m0:m1, c0:c1]), ndisp,
                    limit=params.cross_limit, tau=params.cross_tau,
                    iterations=params.cross_iterations,
                    colour_r=None if guide_r is None else np.ascontiguousarray(
                        guide_r[:, m0:m1, c0:c1]
                    ),
                    dmin=dmin,
                )  # fmt: skip
            cost = volume.reshape(-1)
            luma = np.ascontiguousarray(luma_l[m0:m1, c0:c1])
            sgm_kernels.paths_and_choices(
                cost, luma, down, up, s0 - m0, s1 - m0, k0 - c0, k1 - c0, dmin, ndisp, p1,
                table, diagonals, _SUBPIXEL[params.subpixel], best, value, candidate, margin,
                s0, k0, threads,
            )  # fmt: skip
    finally:
        _POOL.give(held)
    disparity = np.empty((height, width), dtype=np.float32)
    flags = np.empty((height, width), dtype=np.uint8)
    tolerance = -1 if params.lr_tolerance is None else params.lr_tolerance
    sgm_kernels.left_right_check(best, value, candidate, dmin, tolerance, disparity, flags, threads)
    result = DisparityResult(disparity, flags, params, np.full(height, np.nan))
    if (params.fill or params.planes) and colour_l.shape[1:] != (height, width):
        colour_l, _ = colour_channels(left, left, (luma_l, luma_l))  # census: no colours kept
    if params.planes:
        result = refine_planes(result, colour_l, margin)
    if params.fill:
        result = fill_with_colour(result, colour_l)
    return result, margin


#: The key of :func:`~dcstereo.methods._pipeline.run_shared` under which the costs of a run
#: with ``edges`` leave the views as they compared them (the right one after
#: ``row_alignment`` and ``photometric``): ``(colour_l, colour_r)``, for the edges stage.
_VIEWS = "sgm views"


def sgm_views(left: np.ndarray, right: np.ndarray, params: MatchParams):
    """Return the views' channels as ``sgm``'s costs compare them: ``(colour_l, colour_r)``.

    :func:`dcstereo.signal.colour_channels`, the right view's after ``row_alignment`` and
    ``photometric`` (their coarse pass run again); the pair checked.
    """
    left, right = check_pair(left, right)
    with threads_with_cores():
        luma_l, luma_r, colour_l, colour_r = _views(left, right)
        _, colour_r = _aligned_views(left, right, luma_l, luma_r, colour_l, colour_r, params)
    return colour_l, colour_r


def _edges(left, right, params, result):
    """Run :func:`~dcstereo.refine.edges.refine_edges` over the views the costs saw (the stage).

    Left by this run's costs (:data:`_VIEWS`); made again (:func:`sgm_views`) for the
    stage run on its own.
    """
    views = (run_shared() or {}).pop(_VIEWS, None)
    colour_l, colour_r = sgm_views(left, right, params) if views is None else views
    with threads_with_cores():
        return refine_edges(result, colour_l, colour_r)


#: The edges stage (``edges``), after the median.
EDGES = Stage("edges", _edges, when=lambda params: params.edges is not None)


@dataclass(frozen=True, kw_only=True)
class _SemiGlobalParams(MethodParams):
    """What ``sgm`` and ``sgm-accurate`` both read."""

    census_window: tuple[int, int] = option("census_window")
    ad_truncation: int = option("ad_truncation")
    p1: int = option("p1")
    p2: int = option("p2")
    p2_gradient: float = option("p2_gradient")
    paths: int = option("paths")
    lr_tolerance: int | None = option("lr_tolerance")
    aggregation: str | None = option("aggregation")
    cross_limit: int = option("cross_limit")
    cross_tau: float = option("cross_tau")
    cross_iterations: int = option("cross_iterations")
    census_step: int = option("census_step")
    census_smoothing: float = option("census_smoothing")


@dataclass(frozen=True, kw_only=True)
class SGMParams(_SemiGlobalParams):
    """``sgm``'s parameters: census window, colour truncation, penalties, paths, tolerance.

    Defaults as :class:`~dcstereo.MatchParams`' (and :func:`dcstereo.match`'s); the stages
    on request (``planes``, ``photometric``, ``row_alignment``, ``edges``) are off.
    """

    METHOD = "sgm"
    planes: bool | None = option("planes")
    photometric: str | None = option("photometric")
    row_alignment: str | None = option("row_alignment")
    edges: str | None = option("edges")


@dataclass(frozen=True, kw_only=True)
class SGMAccurateParams(_SemiGlobalParams):
    """``sgm-accurate``'s parameters: ``sgm``'s, without the stages it always runs.

    Its stages (:data:`dcstereo.params.FIXED_OPTIONS`) are not fields: another choice of
    them is an :class:`SGMParams` with them named. ``median`` is ``"weighted-planes"``
    unless given.
    """

    METHOD = "sgm-accurate"


METHOD = Method(
    "sgm",
    (
        core(
            "sgm",
            match_sgm,
            "census + colour costs, box, semi-global paths, winner-take-all + sub-pixel fit, "
            "left-right check, colour fill",
        ),
        MEDIAN,
        EDGES,
        FILL,
    ),
    "the default: census, semi-global matching, left-right check, fill, median, sub-pixel",
    params=SGMParams,
)

#: ``sgm`` with the five stages that win on the development scenes, indoor and outdoor
#: (:data:`dcstereo.params.FIXED_OPTIONS`): the right view's colours and rows aligned to
#: the left's, superpixel planes after the left-right check, the weighted median with a
#: local plane per pixel, and the depth edges decided again. The same stages as
#: :data:`dcstereo.methods.sgm.METHOD`, run with those options on.
ACCURATE = Method(
    "sgm-accurate",
    (
        Stage(
            "sgm-accurate",
            METHOD.stages[0].run,
            steps="the right view's colours and rows aligned to the left's, census + colour "
            "costs, box, semi-global paths, winner-take-all + sub-pixel fit, left-right check, "
            "superpixel planes, colour fill",
        ),
        *METHOD.stages[1:],
    ),
    "sgm with its aligned views, superpixel planes, weighted median and local planes, and "
    "edges: the most accurate, about four times sgm's time",
    params=SGMAccurateParams,
)
