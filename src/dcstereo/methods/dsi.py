"""``dsi3`` and ``dsi5``: the scanline DP over the disparity-space image (eq. 5 for ``dsi5``)."""

from dataclasses import dataclass

from dcstereo import _records as records
from dcstereo.methods import _bands
from dcstereo.methods._pipeline import REFINE, Method, MethodParams, core, option
from dcstereo.params import MatchParams
from dcstereo.result import DisparityResult
from dcstereo.scanline import rows


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
    left_p, right_p = _bands._padded_signals(left, right, params.window // 2)
    out = records.outputs(*left.shape[:2])
    step_costs = _bands._step_costs(params, five=params.method == "dsi5")
    if params.cost == "bt" and not _bands._band_array_fits(params, left.shape[1]):
        nchunks = rows.chunk_count(left.shape[0])
        rows.match_dsi_rows(left_p, right_p, _bands._dsi(params), True, step_costs, nchunks, out)
    else:
        _bands._band_rows(left_p, right_p, params, step_costs, out, clock)
    scale = _bands.cost_scale(params.window)
    return DisparityResult(out.disparity, out.flags, params, out.total / (2.0 * scale))


@dataclass(frozen=True, kw_only=True)
class DSI5Params(MethodParams):
    """``dsi5``'s parameters: the occlusion cost and the d and e steps' cost (eq. 5).

    Defaults as :class:`~dcstereo.MatchParams`' (and :func:`dcstereo.match`'s).
    """

    METHOD = "dsi5"
    occlusion_cost: float = option("occlusion_cost")
    slant_cost: float | None = option("slant_cost")


@dataclass(frozen=True, kw_only=True)
class DSI3Params(MethodParams):
    """``dsi3``'s parameters: the occlusion cost of the three-step DP [4]."""

    METHOD = "dsi3"
    occlusion_cost: float = option("occlusion_cost")


DSI3 = Method(
    "dsi3",
    (core("dsi3", _match_dsi, "costs (SAD or BT, eq. 4) + three-step DP [4]"), *REFINE),
    "the three-step scanline DP (Intille and Bobick)",
    params=DSI3Params,
)
DSI5 = Method(
    "dsi5",
    (core("dsi5", _match_dsi, "costs (SAD or BT, eq. 4) + five-step DP (eq. 5)"), *REFINE),
    "the five-step scanline DP of eq. 5",
    params=DSI5Params,
)
