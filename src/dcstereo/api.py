"""``match``: validate the pair, pick the method from a plain dict, return the result."""

from collections.abc import Callable

import numba
import numpy as np

from . import _band_kernels, _kernels
from .params import DEFAULT_METHOD, MatchParams
from .postfilter import median_filter
from .redert import match_redert as _match_redert
from .result import FLAG_FEATURE, DisparityResult
from .sgm import match_sgm as _match_sgm
from .signal import SIGNAL_STEPS, check_pair, padded_signal
from .subpixel import refine_subpixel


def match(
    left: np.ndarray,
    right: np.ndarray,
    *,
    max_disparity: int,
    min_disparity: int = 0,
    method: str = DEFAULT_METHOD,
    **options,
) -> DisparityResult:
    """Estimate the disparity of the left image of a rectified stereo pair.

    A left pixel ``(x, y)`` matches the right pixel ``(x - d, y)``; disparities
    ``min_disparity..max_disparity`` (inclusive) are searched.

    Parameters
    ----------
    left, right : ndarray, shape (H, W) or (H, W, 3|4)
        Rectified pair of one height and width, ``uint8``, ``uint16`` or float in
        ``[0, 1]``; colour becomes luma (see :mod:`dcstereo.signal`), each image on its
        own, so a gray and a colour image may be paired.
    max_disparity, min_disparity : int
        Inclusive search range in pixels.
    method : str
        ``"dc"`` (default): the divide-and-conquer matcher of Tsai and Katsaggelos: reliable
        feature pairs (SER and VS tests, ordering constraint) pin the path of each scanline
        and the five-step DP fills between them; ``"dc-linear"``: the same features,
        interpolated linearly between them; ``"block"``: winner-take-all SAD block matching
        (Hannah);
        ``"dsi3"``: scanline DP over the disparity-space image with the classic three steps
        (Intille and Bobick); ``"dsi5"``: the extended five-step model of eq. 5 (Tsai and
        Katsaggelos); ``"redert"``: the DP with modelling of occlusion and object
        orientation of Redert, Tsai, Hendriks and Katsaggelos (reconstructed; window
        sheared by the surface slope, see :mod:`dcstereo.redert`); ``"dsi3-gcp"``: the
        three-step DP forced through Intille and Bobick's ground control points (textured,
        unambiguous, left-right consistent matches kept in order; see
        :class:`~dcstereo.params.MatchParams`).
    **options
        ``window`` (odd, default 5), ``occlusion_cost`` (per pixel, gray levels of mean
        absolute difference, default 10), ``fill`` (default False), ``cost``
        (``"sad"`` or ``"bt"``, Birchfield-Tomasi), ``subpixel`` (None, ``"equiangular"``
        or ``"parabola"``, see :mod:`dcstereo.subpixel`), ``median`` (0, or the odd side of
        a median filter, see :mod:`dcstereo.postfilter`). See
        :class:`~dcstereo.params.MatchParams`.

    Returns
    -------
    DisparityResult

    Examples
    --------
    >>> import numpy as np, dcstereo
    >>> rng = np.random.default_rng(0)
    >>> right = rng.integers(0, 256, (20, 40), dtype=np.uint8)
    >>> left = np.roll(right, 3, axis=1)  # every left pixel matches x - 3
    >>> result = dcstereo.match(left, right, max_disparity=6)
    >>> float(np.nanmedian(result.disparity))
    3.0
    """
    params = MatchParams(
        max_disparity=max_disparity, min_disparity=min_disparity, method=method, **options
    )
    left, right = check_pair(left, right)
    height, width = left.shape[:2]
    params.check_image_size(height, width)
    try:
        result = _METHODS[params.method](left, right, params)
    except (SystemError, MemoryError) as err:
        # numpy's MemoryError, or numba's SystemError for an allocation that failed inside
        # a parallel kernel: one line that says what did not fit
        if not isinstance(err, MemoryError) and not isinstance(err.__cause__, MemoryError):
            raise
        raise MemoryError(
            f"out of memory matching {height} x {width} images over "
            f"{params.num_disparities} disparities with method {params.method!r}"
        ) from err
    if params.subpixel is not None and params.method != "sgm":  # sgm fits its own costs
        result = refine_subpixel(result, left, right, fit=params.subpixel)
    if params.median:
        result = median_filter(result, params.median)
    return result.filled() if params.fill else result


def _padded_signals(left, right, radius):
    return padded_signal(left, radius), padded_signal(right, radius)


def _doubled(cost: float, scale: float) -> float:
    """Return a per-pixel cost (gray levels) in the kernels' doubled integer units."""
    return float(np.rint(2.0 * cost * scale))


def cost_scale(window: int) -> float:
    """Return the internal cost units per gray level of mean absolute difference."""
    return float(SIGNAL_STEPS * window * window)


def _outputs(shape):
    height, width = shape[:2]
    disparity = np.empty((height, width), dtype=np.float32)
    flags = np.empty((height, width), dtype=np.uint8)
    total = np.empty(height, dtype=np.float64)
    return disparity, flags, total, _kernels.chunk_count(height)


def _features(partner, flags, ser=None, vs=None):
    """Return the feature pairs ``(row, x_left, x_right, SER, VS)`` where ``partner >= 0``.

    Sorted by row and column; SER and VS are NaN when not given. The pairs are marked
    ``FLAG_FEATURE`` in ``flags``.
    """
    if ser is None:
        ser = vs = np.empty((0, 0), dtype=np.float32)
    return _kernels.collect_features(partner, ser, vs, FLAG_FEATURE, flags)


def _match_block(left, right, params: MatchParams) -> DisparityResult:
    """``block``: the least window cost per pixel.

    Runs ``_band_kernels.BAND_ROWS`` rows in lockstep (the same results, bit for bit, as
    the per-row kernel); the Birchfield-Tomasi cost makes the band's cost array first,
    with as many chunks at once as ``BAND_ARRAY_BYTES`` holds arrays, and where one array
    alone would pass it, runs row by row instead.
    """
    radius = params.window // 2
    left_p, right_p = _padded_signals(left, right, radius)
    disparity, flags, total, nchunks = _outputs(left.shape)
    bt = params.cost == "bt"
    if bt and not _band_array_fits(params, left.shape[1]):
        _kernels.match_block_rows(
            left_p,
            right_p,
            params.min_disparity,
            params.num_disparities,
            radius,
            True,
            nchunks,
            disparity,
            flags,
            total,
        )
    else:
        _band_kernels.match_block_bands(
            left_p,
            right_p,
            params.min_disparity,
            params.num_disparities,
            radius,
            _array_chunks(params, left.shape) if bt else _band_chunks(left.shape[0]),
            disparity,
            flags,
            total,
            True if bt else None,  # None: the SAD version compiles without the BT code
        )
    return DisparityResult(disparity, flags, params, total / cost_scale(params.window))


def _match_dsi(left, right, params: MatchParams, clock=None) -> DisparityResult:
    """``dsi3`` / ``dsi5``: the whole-scanline DP of every row.

    Both costs run ``_band_kernels.BAND_ROWS`` rows in lockstep (vectorized across rows;
    the same results, bit for bit, as the per-row kernel ``_kernels.match_dsi_rows``).
    The SAD cost makes each column's costs inside the DP pass; the Birchfield-Tomasi cost
    makes the band's cost array first (as many chunks at once as ``BAND_ARRAY_BYTES``
    holds arrays; where one array alone would pass it, row by row instead). ``clock``: the band
    kernel's stage counters (``match_band_rows``; ``benchmarks/bench_stages.py``), the band
    path only.
    """
    radius = params.window // 2
    left_p, right_p = _padded_signals(left, right, radius)
    disparity, flags, total, nchunks = _outputs(left.shape)
    scale = cost_scale(params.window)
    occ2 = _doubled(params.occlusion_cost, scale)
    slant2 = _doubled(params.effective_slant_cost, scale)
    five = params.method == "dsi5"
    bt = params.cost == "bt"
    if bt and not _band_array_fits(params, left.shape[1]):
        _kernels.match_dsi_rows(
            left_p,
            right_p,
            params.min_disparity,
            params.num_disparities,
            radius,
            True,
            occ2,
            five,
            slant2,
            nchunks,
            disparity,
            flags,
            total,
        )
    else:
        _band_rows(left_p, right_p, params, occ2, five, slant2, (disparity, flags, total), clock)
    return DisparityResult(disparity, flags, params, total / (2.0 * scale))


def _band_rows(
    left_p,
    right_p,
    params,
    occ2,
    five,
    slant2,
    outputs,
    clock=None,
    pin_mode=0,
    partner=None,
    tests=None,
    pairs=None,
    counts=None,
    gcp=False,
):
    """Call ``_band_kernels.match_band_rows`` with ``params``' range, window and cost.

    ``outputs`` is ``(disparity, flags, total)``; the arrays a mode does not read are
    passed empty. ``tests`` None (no pins): the free-mode version compiles without the
    search; the SAD cost passes ``bt`` None, so its version compiles without the BT code,
    and the search of ``dc`` passes ``gcp`` None (``gcp``: ``dsi3-gcp``'s points instead).
    """
    disparity, flags, total = outputs
    if partner is None:
        partner = np.empty((0, 0), dtype=np.int64)
    if pairs is None:
        pairs = np.empty((0, 0, 4), dtype=np.float32)
        counts = np.empty(0, dtype=np.int64)
    _band_kernels.match_band_rows(
        left_p,
        right_p,
        params.min_disparity,
        params.num_disparities,
        params.window // 2,
        occ2,
        five,
        slant2,
        pin_mode,
        partner,
        tests,
        # the BT cost and pin modes 1 and 2 make the band's cost array
        (
            _array_chunks(params, disparity.shape)
            if params.cost == "bt" or pin_mode in (1, 2)
            else _band_chunks(disparity.shape[0])
        ),
        disparity,
        flags,
        total,
        pairs,
        counts,
        clock,
        True if params.cost == "bt" else None,
        True if gcp else None,
    )


#: The most memory (bytes) that the band cost arrays of one call take together: the arrays
#: the band kernels make before their DP for the Birchfield-Tomasi cost (``match_band_rows``'
#: and ``match_block_bands``' ``bt``) and for ``dc``'s kept array (mode 2). Each running
#: chunk makes one array, so the chunks are capped to fit (``_array_chunks``); where one
#: array alone would not fit, the rows run one at a time (a ``(W, D)`` array each). The
#: array is kept even where it leaves the caches: on noise strips of 256 rows, one thread,
#: 4 to 94 MiB arrays, row by row took 2.4-5.2x the time with BT (``block``, ``dsi3``,
#: ``dsi5``), 1.6-3.5x with ``dc`` and BT, 1.5-2.5x with ``dc``'s left-right check
#: (``docs/SPEED.md``, "The band cost array beyond the caches").
BAND_ARRAY_BYTES = 512 * 2**20


def _band_bytes(params: MatchParams, width: int) -> int:
    """Bytes of one band's float64 cost array (``width x (D + 2) x BAND_ROWS``)."""
    return width * (params.num_disparities + 2) * _band_kernels.BAND_ROWS * 8


def _band_array_fits(params: MatchParams, width: int, limit: int | None = None) -> bool:
    """Whether a band's float64 cost array fits ``limit`` (default ``BAND_ARRAY_BYTES``)."""
    return _band_bytes(params, width) <= (BAND_ARRAY_BYTES if limit is None else limit)


def _array_chunks(params: MatchParams, shape: tuple[int, int]) -> int:
    """Chunks of a band kernel that makes the band's cost array, ``shape`` the image's.

    ``_band_chunks``, capped so that the arrays of the chunks that may run at once fit
    ``BAND_ARRAY_BYTES`` together (at least one; the callers run row by row where one
    array does not fit).
    """
    fit = max(1, BAND_ARRAY_BYTES // _band_bytes(params, shape[1]))
    return min(_band_chunks(shape[0]), fit)


def _band_chunks(height: int) -> int:
    """Chunks of the band kernels: four a thread (uneven threads even out), one alone.

    Each chunk starts its vertical window sums afresh and takes its own scratch, so on one
    thread a single chunk is 2-6 % faster than four (``dc`` and ``dsi5`` on the Middlebury
    scenes, alternating in one process); the results do not depend on the chunks.
    """
    threads = numba.get_num_threads()
    bands = -(-height // _band_kernels.BAND_ROWS)
    return 1 if threads == 1 else max(1, min(bands, 4 * threads))


def _match_dc(left, right, params: MatchParams, clock=None) -> DisparityResult:
    """``dc`` / ``dc-linear``: reliable feature pairs pin the path; the DP fills between.

    ``dc`` with the uniqueness test on and no limit on the tries (the defaults) runs on
    the band kernels: the feature search of each row on its band's costs, then the band DP
    through the pairs (``_band_kernels.match_band_rows``; the band's cost array is kept
    while it fits ``DC_BAND_BYTES``, else the SAD costs are made twice, see
    ``_dc_band_mode``; the left-right check and the Birchfield-Tomasi cost keep the array
    up to ``BAND_ARRAY_BYTES``). The other settings, and images whose band array would
    pass that, run row by row
    (``_kernels.match_dc_rows``), which fills each interval between pairs separately.
    Both give the same pairs and maps; the band path's ``path_cost`` is that of the whole
    path through the pairs (the row-by-row one leaves
    out intervals with no left pixel inside). ``clock``: as ``_match_dsi``'s.
    """
    radius = params.window // 2
    left_p, right_p = _padded_signals(left, right, radius)
    disparity, flags, total, nchunks = _outputs(left.shape)
    scale = cost_scale(params.window)
    occ2 = _doubled(params.occlusion_cost, scale)
    band_mode = _dc_band_mode(params, left.shape[1])
    if band_mode:
        # each row's pairs, compactly (only the first few of each row are touched)
        pairs = np.empty((*disparity.shape, 4), dtype=np.float32)
        counts = np.empty(disparity.shape[0], dtype=np.int64)
        tests = (
            float(params.ser_min),
            float(params.vs_max),
            bool(params.vs_relative),
            float(params.feature_floor),
            bool(params.lr_check),
            float(params.uniqueness),
            _edge_guard(params, left.shape[1]),
            int(SIGNAL_STEPS),
        )
        _band_rows(
            left_p,
            right_p,
            params,
            occ2,
            True,
            _doubled(params.effective_slant_cost, scale),
            (disparity, flags, total),
            clock,
            pin_mode=band_mode,
            tests=tests,
            pairs=pairs,
            counts=counts,
        )
        features = _kernels.collect_pairs(pairs, counts, FLAG_FEATURE, flags)
        return DisparityResult(disparity, flags, params, total / (2.0 * scale), features)
    partner = np.empty(disparity.shape, dtype=np.int64)
    ser = np.empty(disparity.shape, dtype=np.float32)
    vs = np.empty(disparity.shape, dtype=np.float32)
    _kernels.match_dc_rows(
        left_p,
        right_p,
        params.min_disparity,
        params.num_disparities,
        radius,
        params.cost == "bt",
        occ2,
        _doubled(params.effective_slant_cost, scale),
        float(params.ser_min),
        float(params.vs_max),
        params.vs_relative,
        float(params.feature_floor),
        min(params.max_candidates, left.shape[1]),  # a row has no more candidates (int64)
        params.lr_check,
        float(params.uniqueness),
        _edge_guard(params, left.shape[1]),
        params.method == "dc-linear",
        SIGNAL_STEPS,
        nchunks,
        disparity,
        flags,
        total,
        partner,
        ser,
        vs,
    )
    features = _features(partner, flags, ser, vs)
    path_cost = total / (2.0 * scale)
    if params.method == "dc-linear":
        path_cost = np.full_like(path_cost, np.nan)
    return DisparityResult(disparity, flags, params, path_cost, features)


def _edge_guard(params: MatchParams, width: int) -> int:
    """``effective_edge_guard`` for the kernels, at most ``width`` (so that it fits int64).

    The kernels clamp the guard columns to the row, so every guard from ``width - 1`` up
    gives the same pairs.
    """
    return min(params.effective_edge_guard, width)


#: Largest band cost array (bytes) that ``dc`` keeps (``match_band_rows`` mode 2: the
#: costs made once, read by the block match, the search and the DP). Beyond it the array
#: leaves the caches and streams through memory three times (3000 x 2000 x 256: 50 MB per
#: band), so ``dc`` makes the costs twice instead, a column at a time (mode 3: once for the
#: block match, once inside the DP, from the vertical sums the first pass left). On noise
#: strips of 256 rows, one thread: 4 MiB arrays (1000 x 64) 67 ms kept against 83 made,
#: 7.9 MiB 128 against 133, 15.9 MiB (2000 x 128) 324 against 260, 23.6 MiB 436 against
#: 345; on the 3000 x 2000 x 256 pair mode 3 beats the row kernel (6.0 s against 7.8).
#: Mode 3 keeps no costs for the search, so the left-right check (which walks the array's
#: diagonals) and the BT cost keep the array past this bound, up to ``BAND_ARRAY_BYTES``.
DC_BAND_BYTES = 8 * 2**20


def _dc_band_mode(params: MatchParams, width: int) -> int:
    """How ``dc`` runs: 0 row by row, else the ``pin_mode`` of ``match_band_rows`` (2, 3)."""
    if not (params.method == "dc" and params.uniqueness > 0 and params.max_candidates == 0):
        return 0
    mode = _search_band_mode(params, width)
    if mode == 2 or (mode == 3 and not params.lr_check):
        return mode
    # the BT cost and dc's left-right check read the band's array, which mode 3 does not
    # keep: kept past the caches, 1.5-3.5x faster than row by row (BAND_ARRAY_BYTES)
    return 2 if _band_array_fits(params, width) else 0


def _search_band_mode(params: MatchParams, width: int) -> int:
    """How a search on the bands (``dc``, ``dsi3-gcp``) runs, by the size of its cost array.

    2: with the band's cost array while it fits ``DC_BAND_BYTES`` (and the memory bound,
    ``BAND_ARRAY_BYTES``); else 3, the SAD costs made twice, inside the passes
    (``dsi3-gcp``'s left-right check then reads the two least costs of each right pixel,
    folded in as the columns are made); 0, row by row, for the BT cost, which needs the
    array (``dsi3-gcp``'s check walks it: past the caches slower than row by row, 16 to 24
    MiB arrays 1.1-1.2x; ``dc`` keeps it, ``_dc_band_mode``).
    """
    if _band_array_fits(params, width, min(DC_BAND_BYTES, BAND_ARRAY_BYTES)):
        return 2
    return 0 if params.cost == "bt" else 3


def _match_gcp(left, right, params: MatchParams) -> DisparityResult:
    """``dsi3-gcp``: the three-step DP forced through ground control points.

    Intille and Bobick's ground control points (see ``_kernels.select_gcps`` and
    :class:`~dcstereo.params.MatchParams`): per row, the left pixels of window variance at
    least ``gcp_variance_floor`` whose whole-band match passes the ``gcp_uniqueness``
    ratio test and the exact left-right check, then the longest subset increasing in both
    ``x_left`` and ``x_right``. They come back as ``features`` (SER and VS NaN) and carry
    ``FLAG_FEATURE``. It runs on the band kernels (``match_band_rows``' ``gcp``: the band's
    costs and block match as for ``dc``, the points of each row from them, the DP through
    them), in ``dc``'s modes (``_search_band_mode``): with the band's cost array while it
    fits ``DC_BAND_BYTES``, else with the SAD cost the costs made twice, a column at a
    time; the Birchfield-Tomasi cost on images too wide for the array runs row by row
    (``_kernels.match_gcp_rows``). All give the same points and maps, bit for bit.
    """
    radius = params.window // 2
    left_p, right_p = _padded_signals(left, right, radius)
    disparity, flags, total, nchunks = _outputs(left.shape)
    partner = np.empty(disparity.shape, dtype=np.int64)
    scale = cost_scale(params.window)
    occ2 = _doubled(params.occlusion_cost, scale)
    mode = _search_band_mode(params, left.shape[1])
    if mode:
        # dc's tests tuple, of which the points read the variance floor, the uniqueness
        # and the signal steps (band_feature_mask, band_lane_variance); no guard (0)
        tests = (0.0, 0.0, False, float(params.gcp_variance_floor), False,
                 float(params.gcp_uniqueness), 0, SIGNAL_STEPS)  # fmt: skip
        outputs = (disparity, flags, total)
        _band_rows(
            left_p, right_p, params, occ2, False, 0.0, outputs, None, mode, partner, tests, gcp=True
        )
    else:
        _kernels.match_gcp_rows(
            left_p,
            right_p,
            params.min_disparity,
            params.num_disparities,
            radius,
            params.cost == "bt",
            occ2,
            float(params.gcp_uniqueness),
            float(params.gcp_variance_floor),
            SIGNAL_STEPS,
            nchunks,
            disparity,
            flags,
            total,
            partner,
        )
    features = _features(partner, flags)
    return DisparityResult(disparity, flags, params, total / (2.0 * scale), features)


_METHODS: dict[str, Callable[[np.ndarray, np.ndarray, MatchParams], DisparityResult]] = {
    "sgm": _match_sgm,
    "block": _match_block,
    "dsi3": _match_dsi,
    "dsi5": _match_dsi,
    "dsi3-gcp": _match_gcp,
    "dc": _match_dc,
    "dc-linear": _match_dc,
    "redert": _match_redert,
}
