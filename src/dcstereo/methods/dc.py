"""``dc`` and ``dc-linear``: the paper's divide and conquer (section 2) and its DP (section 3)."""

from dataclasses import dataclass

import numpy as np

from dcstereo import _records as records
from dcstereo.divide import bands, divide
from dcstereo.methods import _bands
from dcstereo.methods._pipeline import REFINE, Method, MethodParams, core, option
from dcstereo.params import MatchParams
from dcstereo.result import FLAG_FEATURE, DisparityResult
from dcstereo.scanline import rows
from dcstereo.signal import SIGNAL_STEPS


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
    Both give the same pairs, maps and ``path_cost`` (the cost of the whole path through
    the pairs, summed in another order: equal to about 1e-15). The two stay because each
    wins where it runs: the band kernels are 1.5-3.5x faster while the band's array fits
    its bound, and only the row kernel runs the settings that retry pairs per interval
    (``uniqueness=0``, ``max_candidates``). ``clock``: as ``_match_dsi``'s.
    """
    left_p, right_p = _bands._padded_signals(left, right, params.window // 2)
    height, width = left.shape[:2]
    step_costs = _bands._step_costs(params, five=True)
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
    scale = _bands.cost_scale(params.window)
    band_mode = _dc_band_mode(params, width)
    if band_mode != _bands.ROW_BY_ROW:
        # each row's pairs, compactly (only the first few of each row are touched)
        out = records.outputs(height, width, pairs=True)
        _bands._band_rows(
            left_p, right_p, params, step_costs, out, clock, mode=band_mode, tests=tests
        )
        features = divide.collect_pairs(out.pairs, out.counts, FLAG_FEATURE, out.flags)
        path_cost = out.total / (2.0 * scale)
        return DisparityResult(out.disparity, out.flags, params, path_cost, features)
    out = records.outputs(height, width, partner=True, reliability=True)
    nchunks = rows.chunk_count(height)
    bt = params.cost == "bt"
    divide.match_dc_rows(left_p, right_p, _bands._dsi(params), bt, step_costs, tests, nchunks, out)
    features = _bands._features(out.partner, out.flags, out.ser, out.vs)
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


def _dc_band_mode(params: MatchParams, width: int) -> int:
    """How ``dc`` runs: ``_bands.ROW_BY_ROW``, else the ``mode`` of ``match_band_rows``.

    ``bands.SEARCH`` or ``bands.SEARCH_TWICE`` ("modes" 2 and 3: 0 is row by row).
    """
    if not (params.method == "dc" and params.uniqueness > 0 and params.max_candidates == 0):
        return _bands.ROW_BY_ROW
    mode = _bands._search_band_mode(params, width)
    if mode == bands.SEARCH or (mode == bands.SEARCH_TWICE and not params.lr_check):
        return mode
    # the BT cost and dc's left-right check read the band's array, which SEARCH_TWICE does
    # not keep: kept past the caches, 1.5-3.5x faster than row by row (BAND_ARRAY_BYTES)
    return bands.SEARCH if _bands._band_array_fits(params, width) else _bands.ROW_BY_ROW


_DC_STEPS = "costs (eq. 4) + feature pairs (SER eq. 2, VS eq. 3, recursive split) + DP (eq. 5)"


@dataclass(frozen=True, kw_only=True)
class DCParams(MethodParams):
    """``dc``'s parameters: the DP's costs (eq. 5) and the feature pairs' tests (eq. 2 and 3).

    Defaults as :class:`~dcstereo.MatchParams`' (and :func:`dcstereo.match`'s).
    """

    METHOD = "dc"
    occlusion_cost: float = option("occlusion_cost")
    slant_cost: float | None = option("slant_cost")
    ser_min: float = option("ser_min")
    vs_max: float = option("vs_max")
    vs_relative: bool = option("vs_relative")
    feature_floor: float = option("feature_floor")
    max_candidates: int = option("max_candidates")
    lr_check: bool = option("lr_check")
    uniqueness: float = option("uniqueness")
    edge_guard: int | None = option("edge_guard")


@dataclass(frozen=True, kw_only=True)
class DCLinearParams(DCParams):
    """``dc-linear``'s parameters: ``dc``'s (the same feature pairs, interpolated)."""

    METHOD = "dc-linear"


METHOD = Method(
    "dc",
    (core("dc", _match_dc, _DC_STEPS), *REFINE),
    "the paper's method",
    params=DCParams,
)
LINEAR = Method(
    "dc-linear",
    (core("dc-linear", _match_dc, "costs (eq. 4) + feature pairs + linear interpolation"), *REFINE),
    "the paper's feature pairs, interpolated linearly",
    params=DCLinearParams,
)
