"""The small typed records the kernels take: what they compute, the outputs, scratch.

A kernel takes a handful of these instead of a long list of positional arguments. They are
named tuples, which numba passes as plain structures (an attribute is a field, nothing is
looked up at run time). numba compiles one version of a kernel per set of argument types,
and a record's type is the types of its fields, so the records are made by the functions
below, which fix them (int64, float64, bool; arrays of one dtype and rank), and every call
of a kernel shares one compiled version. An argument that a kernel compiles without when
it is None (``tests``, ``bt``, ``clock``, ...) stays an argument of its own: numba prunes
a branch on an argument being None, not on a field of a record.
"""

from typing import NamedTuple

import numpy as np


class Dsi(NamedTuple):
    """The banded disparity-space image a kernel works on (eq. 4, section 3).

    Cells ``d = dmin + k``, ``0 <= k < ndisp``, of window costs over ``2 radius + 1``
    pixels a side.
    """

    dmin: int
    ndisp: int
    radius: int


class StepCosts(NamedTuple):
    """The DP's step costs (eq. 5), in the kernels' doubled integer units.

    ``occ2``: an occlusion step (a, b); ``slant2``: added to the d and e steps; ``five``:
    the five-step model (else the three steps of Intille and Bobick).
    """

    occ2: float
    slant2: float
    five: bool


class FeatureTests(NamedTuple):
    """The tests a feature pair passes (section 2; ``dc``), or a control point (``dsi3-gcp``).

    ``ser_min``, ``vs_max``, ``vs_relative``: SER at least, VS at most (eq. 2, 3; VS divided
    by the sum of the variances); ``var_floor``: the least window variance of a candidate;
    ``lr_check``, ``uniqueness``, ``edge_guard``: this project's left-right check,
    uniqueness ratio and discontinuity guard; ``signal_steps``: the matching signal's steps
    per gray level; ``max_candidates`` (0: no limit) and ``linear`` (``dc-linear``): the row
    search only. ``dsi3-gcp`` reads ``var_floor``, ``uniqueness`` and ``signal_steps``.
    """

    ser_min: float
    vs_max: float
    vs_relative: bool
    var_floor: float
    lr_check: bool
    uniqueness: float
    edge_guard: int
    signal_steps: int
    max_candidates: int
    linear: bool


class Outputs(NamedTuple):
    """What a row or band driver writes, for an image of ``H`` rows and ``W`` columns.

    ``disparity`` (float32, (H, W)), ``flags`` (uint8, (H, W)) and ``total`` (float64,
    (H,): each row's doubled path cost) of every method; ``partner`` (int64, (H, W): each
    pair's right pixel, -1 elsewhere), ``ser`` and ``vs`` (float32, (H, W)) of the row
    search; ``pairs`` (float32, (H, W, 4): each row's pairs, ``x``, ``j``, SER, VS) and
    ``counts`` (int64, (H,)) of the band search. The arrays a call does not write are
    empty (``outputs``).
    """

    disparity: np.ndarray
    flags: np.ndarray
    total: np.ndarray
    partner: np.ndarray
    ser: np.ndarray
    vs: np.ndarray
    pairs: np.ndarray
    counts: np.ndarray


class PathScratch(NamedTuple):
    """Scratch of ``dp.scanline_dp``: its table and the backtracked path (``path_scratch``)."""

    table: np.ndarray
    path_x: np.ndarray
    path_k: np.ndarray
    path_s: np.ndarray


class DivideScratch(NamedTuple):
    """Scratch of ``divide.divide_row``, so that a row allocates nothing (``divide_scratch``)."""

    path: PathScratch
    stack: np.ndarray
    tree_v: np.ndarray
    tree_i: np.ndarray
    iwork: np.ndarray
    fwork: np.ndarray


class RowOutputs(NamedTuple):
    """One row of the row search's :class:`Outputs`.

    Views of ``disparity``, ``flags``, ``partner``, ``ser`` and ``vs``.
    """

    disparity: np.ndarray
    flags: np.ndarray
    partner: np.ndarray
    ser: np.ndarray
    vs: np.ndarray


class SearchScratch(NamedTuple):
    """Scratch of the band search of one row (``divide_bands.band_row_features``).

    ``iwork`` (int64, (6 + levels, width), ``2**(levels - 1) >= width``), ``fwork``
    (float64, (4, width)), the work list ``stack`` (int64, (width + 2, 6)).
    """

    iwork: np.ndarray
    fwork: np.ndarray
    stack: np.ndarray


class BandMatches(NamedTuple):
    """What the band search reads of a band's pixels, ``x * R + r``.

    ``var``: the left view's window variances (``band_costs.band_lane_variance``);
    ``wta_k`` and ``wta_ratio``: the whole-band block match and its uniqueness ratio
    (``band_match.band_block_match``); ``keep``: the cheap tests' outcome
    (``divide_bands.band_feature_mask``).
    """

    var: np.ndarray
    wta_k: np.ndarray
    wta_ratio: np.ndarray
    keep: np.ndarray


class CostPass(NamedTuple):
    """What a pass makes a band's cost columns from, one at a time (``band_costs._cost_column``).

    ``left_t``, ``right_t``: the band's rows as lanes (``band_costs.band_lane_signals``);
    ``dmin``, ``radius``: the disparities' start and the window; ``spread``: scratch;
    ``vs``: the vertical window sums, whose state is ``sums`` (``band_costs.SUMS_AFRESH``,
    ``SUMS_MOVED``, ``SUMS_READY``); ``hsum``: the running horizontal sums.
    """

    left_t: np.ndarray
    right_t: np.ndarray
    dmin: int
    radius: int
    spread: np.ndarray
    vs: np.ndarray
    sums: int
    hsum: np.ndarray


class Anchors(NamedTuple):
    """The pins of a band's DP and the values it gives its anchors (``band_dp.band_forward``).

    ``pins[x * R + r]`` (int64): the right pixel band row ``r`` is pinned to at ``x`` (-1:
    none); ``pinned[x]`` (bool): whether any row is; ``total`` (float64) and ``steps``
    (int64), ``x * R + r``: each anchor's value and the step into it.
    """

    pins: np.ndarray
    pinned: np.ndarray
    total: np.ndarray
    steps: np.ndarray


class RedertModel(NamedTuple):
    """The model of ``redert``'s DP (``redert.scanline_dp``), its costs in kernel units.

    ``steps``: the sampling resolution (positions in ``1 / steps`` pixel); ``oq`` (int64,
    (O,)): the orientations' slopes in units of ``1 / steps``; ``occ``: an occluded pixel;
    ``discount``: taken off the 2nd to ``run_cap``-th pixel of a run of occlusions;
    ``orient``: a change of orientation; ``slant``: a segment that changes the disparity.
    """

    steps: int
    oq: np.ndarray
    occ: float
    discount: float
    run_cap: int
    orient: float
    slant: float


class RedertScratch(NamedTuple):
    """Scratch of ``redert.scanline_dp``: its ring ``table``, ``back`` pointers, the path."""

    table: np.ndarray
    back: np.ndarray
    path_x: np.ndarray
    path_k: np.ndarray
    path_st: np.ndarray


def dsi(dmin, ndisp, radius) -> Dsi:
    """Return a :class:`Dsi` of int64 fields."""
    return Dsi(int(dmin), int(ndisp), int(radius))


def step_costs(occ2, slant2=0.0, five=False) -> StepCosts:
    """Return a :class:`StepCosts` of float64 costs and a bool."""
    return StepCosts(float(occ2), float(slant2), bool(five))


def feature_tests(
    *,
    ser_min=0.0,
    vs_max=0.0,
    vs_relative=False,
    var_floor=0.0,
    lr_check=False,
    uniqueness=0.0,
    edge_guard=0,
    signal_steps=1,
    max_candidates=0,
    linear=False,
) -> FeatureTests:
    """Return a :class:`FeatureTests` of fixed field types (the defaults: no test)."""
    return FeatureTests(
        float(ser_min),
        float(vs_max),
        bool(vs_relative),
        float(var_floor),
        bool(lr_check),
        float(uniqueness),
        int(edge_guard),
        int(signal_steps),
        int(max_candidates),
        bool(linear),
    )


def outputs(height, width, *, partner=False, reliability=False, pairs=False) -> Outputs:
    """Return new :class:`Outputs` of an image, uninitialised (the drivers write them).

    ``partner``, ``ser``/``vs`` (``reliability``) and ``pairs``/``counts`` of the image's
    size where asked, else empty.
    """
    shape = (height, width) if partner else (0, 0)
    per_pixel = (height, width) if reliability else (0, 0)
    return Outputs(
        np.empty((height, width), dtype=np.float32),
        np.empty((height, width), dtype=np.uint8),
        np.empty(height, dtype=np.float64),
        np.empty(shape, dtype=np.int64),
        np.empty(per_pixel, dtype=np.float32),
        np.empty(per_pixel, dtype=np.float32),
        np.empty((height, width, 4) if pairs else (0, 0, 4), dtype=np.float32),
        np.empty(height if pairs else 0, dtype=np.int64),
    )


def redert_model(steps, oq, occ, discount, run_cap, orient, slant) -> RedertModel:
    """Return a :class:`RedertModel` of fixed field types (``oq`` as int64)."""
    return RedertModel(
        int(steps),
        np.ascontiguousarray(oq, dtype=np.int64),
        float(occ),
        float(discount),
        int(run_cap),
        float(orient),
        float(slant),
    )
