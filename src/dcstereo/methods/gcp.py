"""``dsi3-gcp``: the three-step DP forced through Intille and Bobick's ground control points."""

from dataclasses import dataclass

from dcstereo import _records as records
from dcstereo.divide import gcp
from dcstereo.methods import _bands
from dcstereo.methods._pipeline import REFINE, Method, MethodParams, core, option
from dcstereo.params import MatchParams
from dcstereo.result import DisparityResult
from dcstereo.scanline import rows
from dcstereo.signal import SIGNAL_STEPS


def _match_gcp(left, right, params: MatchParams) -> DisparityResult:
    """``dsi3-gcp``: the three-step DP forced through ground control points.

    Intille and Bobick's ground control points (see ``gcp.select_gcps`` and
    :class:`~dcstereo.params.MatchParams`): per row, the left pixels of window variance at
    least ``gcp_variance_floor`` whose whole-band match passes the ``gcp_uniqueness``
    ratio test and the exact left-right check, then the longest subset increasing in both
    ``x_left`` and ``x_right``. They come back as ``features`` (SER and VS NaN) and carry
    ``FLAG_FEATURE``. It runs on the band kernels (``match_band_rows``' ``gcp``: the band's
    costs and block match as for ``dc``, the points of each row from them, the DP through
    them), in ``dc``'s modes (``_bands._search_band_mode``): with the band's cost array while it
    fits ``DC_BAND_BYTES``, else with the SAD cost the costs made twice, a column at a
    time; the Birchfield-Tomasi cost on images too wide for the array runs row by row
    (``gcp.match_gcp_rows``). All give the same points and maps, bit for bit.
    """
    left_p, right_p = _bands._padded_signals(left, right, params.window // 2)
    height, width = left.shape[:2]
    out = records.outputs(height, width, partner=True)
    step_costs = _bands._step_costs(params, five=False)
    # the points read the variance floor, the uniqueness and the signal steps
    # (band_feature_mask, band_lane_variance); no guard
    tests = records.feature_tests(
        var_floor=params.gcp_variance_floor,
        uniqueness=params.gcp_uniqueness,
        signal_steps=SIGNAL_STEPS,
    )
    mode = _bands._search_band_mode(params, width)
    if mode != _bands.ROW_BY_ROW:
        _bands._band_rows(
            left_p, right_p, params, step_costs, out, mode=mode, tests=tests, gcp=True
        )
    else:
        nchunks = rows.chunk_count(height)
        bt = params.cost == "bt"
        gcp.match_gcp_rows(
            left_p, right_p, _bands._dsi(params), bt, step_costs, tests, nchunks, out
        )
    features = _bands._features(out.partner, out.flags)
    scale = _bands.cost_scale(params.window)
    return DisparityResult(out.disparity, out.flags, params, out.total / (2.0 * scale), features)


@dataclass(frozen=True, kw_only=True)
class GCPParams(MethodParams):
    """``dsi3-gcp``'s parameters: the occlusion cost and the control points' tests.

    Defaults as :class:`~dcstereo.MatchParams`' (and :func:`dcstereo.match`'s).
    """

    METHOD = "dsi3-gcp"
    occlusion_cost: float = option("occlusion_cost")
    gcp_uniqueness: float = option("gcp_uniqueness")
    gcp_variance_floor: float = option("gcp_variance_floor")


METHOD = Method(
    "dsi3-gcp",
    (core("dsi3-gcp", _match_gcp, "costs + ground control points + three-step DP"), *REFINE),
    "the three-step DP through ground control points (Intille and Bobick)",
    params=GCPParams,
)
