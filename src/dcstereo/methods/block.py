"""``block``: winner-take-all SAD (or Birchfield-Tomasi) block matching (Hannah)."""

from dataclasses import dataclass

from dcstereo import _records as records
from dcstereo.divide import bands
from dcstereo.methods import _bands
from dcstereo.methods._pipeline import REFINE, Method, MethodParams, core
from dcstereo.params import MatchParams
from dcstereo.result import DisparityResult
from dcstereo.scanline import rows


def _match_block(left, right, params: MatchParams) -> DisparityResult:
    """``block``: the least window cost per pixel.

    Runs ``bands.BAND_ROWS`` rows in lockstep (the same results, bit for bit, as
    the per-row kernel); the Birchfield-Tomasi cost makes the band's cost array first,
    with as many chunks at once as ``BAND_ARRAY_BYTES`` holds arrays, and where one array
    alone would pass it, runs row by row instead.
    """
    left_p, right_p = _bands._padded_signals(left, right, params.window // 2)
    out = records.outputs(*left.shape[:2])
    bt = params.cost == "bt"
    if bt and not _bands._band_array_fits(params, left.shape[1]):
        nchunks = rows.chunk_count(left.shape[0])
        rows.match_block_rows(left_p, right_p, _bands._dsi(params), True, nchunks, out)
    else:
        nchunks = (
            _bands._array_chunks(params, left.shape) if bt else _bands._band_chunks(left.shape[0])
        )
        # SAD_COST: the version compiled without the BT code
        cost = bands.BT_COST if bt else bands.SAD_COST
        bands.match_block_bands(left_p, right_p, _bands._dsi(params), nchunks, out, cost)
    return DisparityResult(
        out.disparity, out.flags, params, out.total / _bands.cost_scale(params.window)
    )


@dataclass(frozen=True, kw_only=True)
class BlockParams(MethodParams):
    """``block``'s parameters: what every method reads, nothing more."""

    METHOD = "block"


METHOD = Method(
    "block",
    (core("block", _match_block, "costs (SAD or BT, eq. 4) + winner-take-all"), *REFINE),
    "winner-take-all block matching (Hannah)",
    params=BlockParams,
)
