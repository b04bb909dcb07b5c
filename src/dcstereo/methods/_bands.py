"""What the paper's methods share: the band kernels' arguments, chunks and memory bounds.

``block``, ``dsi3``, ``dsi5``, ``dc``, ``dc-linear`` and ``dsi3-gcp`` run the band kernels
(:mod:`dcstereo.divide.bands`: ``BAND_ROWS`` rows in lockstep) or, where a band's cost array
would not fit the bounds below, the row kernels; both give the same maps, bit for bit.
"""

import numba
import numpy as np

from dcstereo import _records as records
from dcstereo.divide import bands, divide
from dcstereo.params import MatchParams
from dcstereo.result import FLAG_FEATURE
from dcstereo.signal import SIGNAL_STEPS, padded_signal


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


def _band_rows(
    left_p, right_p, params, step_costs, out, clock=None, mode=bands.FREE, tests=None, gcp=False
):
    """Call ``bands.match_band_rows`` with ``params``' range, window and cost.

    ``out``: the call's ``records.Outputs`` (the arrays a mode does not write empty).
    ``tests`` None (``mode`` ``bands.FREE``): the free-mode version compiles without the
    search; the SAD cost passes ``bands.SAD_COST``, so its version compiles without the BT
    code (``bands.BT_COST`` with it), and ``dc``'s search passes ``bands.FEATURE_SEARCH``
    (``gcp``: ``bands.GCP_POINTS``, ``dsi3-gcp``'s points instead).
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
        bands.BT_COST if params.cost == "bt" else bands.SAD_COST,
        bands.GCP_POINTS if gcp else bands.FEATURE_SEARCH,
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
