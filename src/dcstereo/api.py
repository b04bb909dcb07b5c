"""``match``: validate the pair, pick the method from a plain dict, return the result."""

from collections.abc import Callable

import numba
import numpy as np

from .kernels import bands, divide, gcp, records, rows
from .params import DEFAULT_METHOD, MatchParams
from .postfilter import median_filter
from .redert import match_redert as _match_redert
from .result import FLAG_FEATURE, DisparityResult
from .sgm import match_sgm as _match_sgm
from .sgm import threads_with_cores
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
    >>> round(float(np.nanmedian(result.disparity)), 2)  # sgm's sub-pixel estimates
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
        with threads_with_cores():  # as sgm's own stages: the threads that have a core
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


def _dsi(params: MatchParams) -> records.Dsi:
    """Return the kernels' disparities and window (``records.Dsi``) of ``params``."""
    return records.dsi(params.min_disparity, params.num_disparities, params.window // 2)


def _step_costs(params: MatchParams, five: bool) -> records.StepCosts:
    """Return the DP's step costs of ``params``, doubled units (``records.StepCosts``).

    ``five``: the five-step model, with ``params``' slant cost; else the three steps.
    """
    scale = cost_scale(params.window)
    slant2 = _doubled(params.effective_slant_cost, scale) if five else 0.0
    return records.step_costs(_doubled(params.occlusion_cost, scale), slant2, five)


def _features(partner, flags, ser=None, vs=None):
    """Return the feature pairs ``(row, x_left, x_right, SER, VS)`` where ``partner >= 0``.

    Sorted by row and column; SER and VS are NaN when not given. The pairs are marked
    ``FLAG_FEATURE`` in ``flags``.
    """
    if ser is None:
        ser = vs = np.empty((0, 0), dtype=np.float32)
    return divide.collect_features(partner, ser, vs, FLAG_FEATURE, flags)


def _match_block(left, right, params: MatchParams) -> DisparityResult:
    """``block``: the least window cost per pixel.

    Runs ``bands.BAND_ROWS`` rows in lockstep (the same results, bit for bit, as
    the per-row kernel); the Birchfield-Tomasi cost makes the band's cost array first,
    with as many chunks at once as ``BAND_ARRAY_BYTES`` holds arrays, and where one array
    alone would pass it, runs row by row instead.
    """
    left_p, right_p = _padded_signals(left, right, params.window // 2)
    out = records.outputs(*left.shape[:2])
    bt = params.cost == "bt"
    if bt and not _band_array_fits(params, left.shape[1]):
        nchunks = rows.chunk_count(left.shape[0])
        rows.match_block_rows(left_p, right_p, _dsi(params), True, nchunks, out)
    else:
        nchunks = _array_chunks(params, left.shape) if bt else _band_chunks(left.shape[0])
        # bt None: the SAD version compiles without the BT code
        bands.match_block_bands(left_p, right_p, _dsi(params), nchunks, out, True if bt else None)
    return DisparityResult(out.disparity, out.flags, params, out.total / cost_scale(params.window))


def _match_dsi(left, right, params: MatchParams, clock=None) -> DisparityResult:
    """``dsi3`` / ``dsi5``: the whole-scanline DP of every row.

    Both costs run ``bands.BAND_ROWS`` rows in lockstep (vectorized across rows;
    the same results, bit for bit, as the per-row kernel ``rows.match_dsi_rows``).
    The SAD cost makes each column's costs inside the DP pass; the Birchfield-Tomasi cost
    makes the band's cost array first (as many chunks at once as ``BAND_ARRAY_BYTES``
    holds arrays; where one array alone would pass it, row by row instead). ``clock``: the band
    kernel's stage counters (``match_band_rows``; ``benchmarks/bench_stages.py``), the band
    path only.
    """
    left_p, right_p = _padded_signals(left, right, params.window // 2)
    out = records.outputs(*left.shape[:2])
    step_costs = _step_costs(params, five=params.method == "dsi5")
    if params.cost == "bt" and not _band_array_fits(params, left.shape[1]):
        nchunks = rows.chunk_count(left.shape[0])
        rows.match_dsi_rows(left_p, right_p, _dsi(params), True, step_costs, nchunks, out)
    else:
        _band_rows(left_p, right_p, params, step_costs, out, clock)
    scale = cost_scale(params.window)
    return DisparityResult(out.disparity, out.flags, params, out.total / (2.0 * scale))


def _band_rows(
    left_p, right_p, params, step_costs, out, clock=None, mode=bands.FREE, tests=None, gcp=False
):
    """Call ``bands.match_band_rows`` with ``params``' range, window and cost.

    ``out``: the call's ``records.Outputs`` (the arrays a mode does not write empty).
    ``tests`` None (``mode`` ``bands.FREE``): the free-mode version compiles without the
    search; the SAD cost passes ``bt`` None, so its version compiles without the BT code,
    and the search of ``dc`` passes ``gcp`` None (``gcp``: ``dsi3-gcp``'s points instead).
    """
    # the BT cost and the modes that keep the band's cost array make it first
    keeps_array = params.cost == "bt" or mode in (bands.PINS_GIVEN, bands.SEARCH)
    nchunks = (
        _array_chunks(params, out.disparity.shape)
        if keeps_array
        else _band_chunks(out.disparity.shape[0])
    )
    bands.match_band_rows(
        left_p,
        right_p,
        _dsi(params),
        step_costs,
        mode,
        tests,
        nchunks,
        out,
        clock,
        True if params.cost == "bt" else None,
        True if gcp else None,
    )


#: The most memory (bytes) that the band cost arrays of one call take together: the arrays
#: the band kernels make before their DP for the Birchfield-Tomasi cost (``match_band_rows``'
#: and ``match_block_bands``' ``bt``) and for ``dc``'s kept array (``bands.SEARCH``). Each running
#: chunk makes one array, so the chunks are capped to fit (``_array_chunks``); where one
#: array alone would not fit, the rows run one at a time (a ``(W, D)`` array each). The
#: array is kept even where it leaves the caches: on noise strips of 256 rows, one thread,
#: 4 to 94 MiB arrays, row by row took 2.4-5.2x the time with BT (``block``, ``dsi3``,
#: ``dsi5``), 1.6-3.5x with ``dc`` and BT, 1.5-2.5x with ``dc``'s left-right check
#: (``docs/SPEED.md``, "The band cost array beyond the caches").
BAND_ARRAY_BYTES = 512 * 2**20


def _band_bytes(params: MatchParams, width: int) -> int:
    """Bytes of one band's float64 cost array (``width x (D + 2) x BAND_ROWS``)."""
    return width * (params.num_disparities + 2) * bands.BAND_ROWS * 8


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
    nbands = -(-height // bands.BAND_ROWS)
    return 1 if threads == 1 else max(1, min(nbands, 4 * threads))


def _match_dc(left, right, params: MatchParams, clock=None) -> DisparityResult:
    """``dc`` / ``dc-linear``: reliable feature pairs pin the path; the DP fills between.

    ``dc`` with the uniqueness test on and no limit on the tries (the defaults) runs on
    the band kernels: the feature search of each row on its band's costs, then the band DP
    through the pairs (``bands.match_band_rows``; the band's cost array is kept
    while it fits ``DC_BAND_BYTES``, else the SAD costs are made twice, see
    ``_dc_band_mode``; the left-right check and the Birchfield-Tomasi cost keep the array
    up to ``BAND_ARRAY_BYTES``). The other settings, and images whose band array would
    pass that, run row by row
    (``divide.match_dc_rows``), which fills each interval between pairs separately.
    Both give the same pairs and maps; the band path's ``path_cost`` is that of the whole
    path through the pairs (the row-by-row one leaves
    out intervals with no left pixel inside). ``clock``: as ``_match_dsi``'s.
    """
    left_p, right_p = _padded_signals(left, right, params.window // 2)
    height, width = left.shape[:2]
    step_costs = _step_costs(params, five=True)
    tests = records.feature_tests(
        ser_min=params.ser_min,
        vs_max=params.vs_max,
        vs_relative=params.vs_relative,
        var_floor=params.feature_floor,
        lr_check=params.lr_check,
        uniqueness=params.uniqueness,
        edge_guard=_edge_guard(params, width),
        signal_steps=SIGNAL_STEPS,
        max_candidates=min(params.max_candidates, width),  # a row has no more candidates
        linear=params.method == "dc-linear",
    )
    scale = cost_scale(params.window)
    band_mode = _dc_band_mode(params, width)
    if band_mode != ROW_BY_ROW:
        # each row's pairs, compactly (only the first few of each row are touched)
        out = records.outputs(height, width, pairs=True)
        _band_rows(left_p, right_p, params, step_costs, out, clock, mode=band_mode, tests=tests)
        features = divide.collect_pairs(out.pairs, out.counts, FLAG_FEATURE, out.flags)
        path_cost = out.total / (2.0 * scale)
        return DisparityResult(out.disparity, out.flags, params, path_cost, features)
    out = records.outputs(height, width, partner=True, reliability=True)
    nchunks = rows.chunk_count(height)
    bt = params.cost == "bt"
    divide.match_dc_rows(left_p, right_p, _dsi(params), bt, step_costs, tests, nchunks, out)
    features = _features(out.partner, out.flags, out.ser, out.vs)
    path_cost = out.total / (2.0 * scale)
    if params.method == "dc-linear":
        path_cost = np.full_like(path_cost, np.nan)
    return DisparityResult(out.disparity, out.flags, params, path_cost, features)


def _edge_guard(params: MatchParams, width: int) -> int:
    """``effective_edge_guard`` for the kernels, at most ``width`` (so that it fits int64).

    The kernels clamp the guard columns to the row, so every guard from ``width - 1`` up
    gives the same pairs.
    """
    return min(params.effective_edge_guard, width)


#: Largest band cost array (bytes) that ``dc`` keeps (``match_band_rows``' ``bands.SEARCH``,
#: "mode 2" in docs/SPEED.md: the costs made once, read by the block match, the search and
#: the DP). Beyond it the array leaves the caches and streams through memory three times
#: (3000 x 2000 x 256: 50 MB per band), so ``dc`` makes the costs twice instead, a column
#: at a time (``bands.SEARCH_TWICE``, "mode 3": once for the block match, once inside the
#: DP, from the vertical sums the first pass left). On noise strips of 256 rows, one
#: thread: 4 MiB arrays (1000 x 64) 67 ms kept against 83 made, 7.9 MiB 128 against 133,
#: 15.9 MiB (2000 x 128) 324 against 260, 23.6 MiB 436 against 345; on the 3000 x 2000 x
#: 256 pair SEARCH_TWICE beats the row kernel (6.0 s against 7.8). SEARCH_TWICE keeps no
#: costs for the search, so the left-right check (which walks the array's diagonals) and
#: the BT cost keep the array past this bound, up to ``BAND_ARRAY_BYTES``.
DC_BAND_BYTES = 8 * 2**20


#: ``_dc_band_mode`` and ``_search_band_mode``: the search runs row by row (else on the
#: bands, in ``match_band_rows``' mode ``bands.SEARCH`` or ``bands.SEARCH_TWICE``).
ROW_BY_ROW = 0


def _dc_band_mode(params: MatchParams, width: int) -> int:
    """How ``dc`` runs: ``ROW_BY_ROW``, else the ``mode`` of ``match_band_rows``.

    ``bands.SEARCH`` or ``bands.SEARCH_TWICE`` ("modes" 2 and 3: 0 is row by row).
    """
    if not (params.method == "dc" and params.uniqueness > 0 and params.max_candidates == 0):
        return ROW_BY_ROW
    mode = _search_band_mode(params, width)
    if mode == bands.SEARCH or (mode == bands.SEARCH_TWICE and not params.lr_check):
        return mode
    # the BT cost and dc's left-right check read the band's array, which SEARCH_TWICE does
    # not keep: kept past the caches, 1.5-3.5x faster than row by row (BAND_ARRAY_BYTES)
    return bands.SEARCH if _band_array_fits(params, width) else ROW_BY_ROW


def _search_band_mode(params: MatchParams, width: int) -> int:
    """How a search on the bands (``dc``, ``dsi3-gcp``) runs, by the size of its cost array.

    ``bands.SEARCH`` (2): with the band's cost array while it fits ``DC_BAND_BYTES`` (and
    the memory bound, ``BAND_ARRAY_BYTES``); else ``bands.SEARCH_TWICE`` (3), the SAD costs
    made twice, inside the passes (``dsi3-gcp``'s left-right check then reads the two least
    costs of each right pixel, folded in as the columns are made); ``ROW_BY_ROW`` (0) for
    the BT cost, which needs the array (``dsi3-gcp``'s check walks it: past the caches
    slower than row by row, 16 to 24 MiB arrays 1.1-1.2x; ``dc`` keeps it,
    ``_dc_band_mode``).
    """
    if _band_array_fits(params, width, min(DC_BAND_BYTES, BAND_ARRAY_BYTES)):
        return bands.SEARCH
    return ROW_BY_ROW if params.cost == "bt" else bands.SEARCH_TWICE


def _match_gcp(left, right, params: MatchParams) -> DisparityResult:
    """``dsi3-gcp``: the three-step DP forced through ground control points.

    Intille and Bobick's ground control points (see ``gcp.select_gcps`` and
    :class:`~dcstereo.params.MatchParams`): per row, the left pixels of window variance at
    least ``gcp_variance_floor`` whose whole-band match passes the ``gcp_uniqueness``
    ratio test and the exact left-right check, then the longest subset increasing in both
    ``x_left`` and ``x_right``. They come back as ``features`` (SER and VS NaN) and carry
    ``FLAG_FEATURE``. It runs on the band kernels (``match_band_rows``' ``gcp``: the band's
    costs and block match as for ``dc``, the points of each row from them, the DP through
    them), in ``dc``'s modes (``_search_band_mode``): with the band's cost array while it
    fits ``DC_BAND_BYTES``, else with the SAD cost the costs made twice, a column at a
    time; the Birchfield-Tomasi cost on images too wide for the array runs row by row
    (``gcp.match_gcp_rows``). All give the same points and maps, bit for bit.
    """
    left_p, right_p = _padded_signals(left, right, params.window // 2)
    height, width = left.shape[:2]
    out = records.outputs(height, width, partner=True)
    step_costs = _step_costs(params, five=False)
    # the points read the variance floor, the uniqueness and the signal steps
    # (band_feature_mask, band_lane_variance); no guard
    tests = records.feature_tests(
        var_floor=params.gcp_variance_floor,
        uniqueness=params.gcp_uniqueness,
        signal_steps=SIGNAL_STEPS,
    )
    mode = _search_band_mode(params, width)
    if mode != ROW_BY_ROW:
        _band_rows(left_p, right_p, params, step_costs, out, mode=mode, tests=tests, gcp=True)
    else:
        nchunks = rows.chunk_count(height)
        bt = params.cost == "bt"
        gcp.match_gcp_rows(left_p, right_p, _dsi(params), bt, step_costs, tests, nchunks, out)
    features = _features(out.partner, out.flags)
    scale = cost_scale(params.window)
    return DisparityResult(out.disparity, out.flags, params, out.total / (2.0 * scale), features)


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
