"""Frozen, validated parameters of :func:`dcstereo.match`."""

import math
from dataclasses import dataclass, fields

import numpy as np

#: Methods understood by :func:`dcstereo.match`, in the order the docs present them.
METHODS = (
    "sgm", "sgm-accurate", "dc", "dc-linear", "dsi5", "dsi3", "dsi3-gcp", "redert", "block",
)  # fmt: skip

#: The methods built on ``sgm``'s semi-global pipeline: they read its options.
SGM_METHODS = ("sgm", "sgm-accurate")

#: The method :func:`dcstereo.match` runs when none is named.
DEFAULT_METHOD = "sgm"

#: Default occlusion cost per pixel, in gray levels of mean absolute difference.
DEFAULT_OCCLUSION_COST = 10.0

#: Cost of a d or e step of the five-step model (eq. 5), per step, in the units of
#: ``occlusion_cost``, for ``dsi5``: 0, the paper's model.
DEFAULT_SLANT_COST = 0.0

#: The same for the fill DP of ``dc`` and ``dc-linear`` (see ``docs/guide/methods.md``).
DEFAULT_DC_SLANT_COST = 8.0

#: Reliability defaults of the divide-and-conquer methods (see ``docs/guide/methods.md``).
DEFAULT_SER_MIN = 1.0
DEFAULT_VS_MAX = 0.2
DEFAULT_FEATURE_FLOOR = 100.0
DEFAULT_UNIQUENESS = 2.0

#: ``dsi3-gcp`` defaults (measured on the dev scenes, ``scripts/measure_gcp_bt.py``).
DEFAULT_GCP_UNIQUENESS = 3.0
#: ``dsi3-gcp``: least window variance of a control point (gray levels squared).
DEFAULT_GCP_VARIANCE_FLOOR = 100.0

#: Largest window: the band kernels sum a window's absolute differences (each at most
#: 255 gray levels in 1/16 steps, 4080) in 32-bit integers, and 4080 * 725**2 < 2**31.
MAX_WINDOW = 725

#: Largest window with ``cost="bt"``: the kernels sum doubled Birchfield-Tomasi
#: dissimilarities (each at most 2 * 4080) in 32-bit integers, and 8160 * 513**2 < 2**31.
MAX_BT_WINDOW = 513

#: Matching costs: the paper's windowed SAD (eq. 4) and Birchfield-Tomasi's
#: sampling-insensitive dissimilarity summed over the same window (the scanline methods);
#: the census transform, alone or with a truncated colour difference (``sgm``).
COSTS = ("sad", "bt", "census", "census-ad")

#: The costs each method takes.
METHOD_COSTS = {
    "sgm": ("census", "census-ad"),
    "sgm-accurate": ("census-ad",),  # its photometric stage aligns the colour term
    "redert": ("sad",),
}
_SCANLINE_COSTS = ("sad", "bt")


def costs_of(method: str) -> tuple[str, ...]:
    """Return the costs (``cost=``) that ``method`` takes."""
    return METHOD_COSTS.get(base_method(method), _SCANLINE_COSTS)


#: Method defaults of the options whose default depends on the method (``None`` given or
#: left out: the method's value). ``sgm`` returns a filled, median-filtered map; the
#: scanline methods of the paper the raw one.
METHOD_DEFAULTS = {
    "sgm": {
        "window": 3,
        "cost": "census-ad",
        "fill": True,
        "median": 5,
        "subpixel": "equiangular",
        "planes": False,
    },
    "sgm-accurate": {
        "window": 3,
        "cost": "census-ad",
        "fill": True,
        "median": "weighted-planes",
        "subpixel": "equiangular",
    },
    None: {
        "window": 5,
        "cost": "sad",
        "fill": False,
        "median": 0,
        "subpixel": None,
        "planes": False,
    },
}

#: The stages a method always runs: options of ``sgm`` that such a method fixes (given to
#: it, only their fixed value or the option's default is taken). ``sgm-accurate`` is
#: ``sgm`` with the five stages that won on the development scenes, indoor and outdoor
#: (``docs/guide/methods.md``); another choice of stages is ``sgm`` with them named.
FIXED_OPTIONS = {
    "sgm-accurate": {
        "photometric": "matched",
        "planes": True,
        "row_alignment": "estimated",
        "edges": "support-weights",
    },
}


def spelled_out(options: dict) -> dict:
    """Return :func:`dcstereo.match`'s keyword arguments with a method of fixed stages as ``sgm``.

    For a method of :data:`FIXED_OPTIONS` (``sgm-accurate``): ``method="sgm"``, its fixed
    stages and its defaults named, so that a caller may then turn one of its stages off
    (the bands of :func:`dcstereo.batch.tiling.match_tiled` run the median and the edges once, on
    the stitched map); the same result. Other options are returned as they are.

    >>> spelled_out({"method": "sgm-accurate", "max_disparity": 8})["median"]
    'weighted-planes'
    """
    method = options.get("method", DEFAULT_METHOD)
    if method not in FIXED_OPTIONS:
        return dict(options)
    given = {name: value for name, value in options.items() if value is not None}
    return {**METHOD_DEFAULTS[method], **given, **FIXED_OPTIONS[method], "method": "sgm"}


#: ``subpixel`` values that turn the fit off (None is the method's default).
SUBPIXEL_OFF = (False, "none")

#: ``sgm`` defaults (measured on the 21 development scenes, ``scripts/tune_sgm.py``).
DEFAULT_CENSUS_WINDOW = (5, 5)
DEFAULT_AD_TRUNCATION = 20
DEFAULT_P1 = 60
DEFAULT_P2 = 400
DEFAULT_P2_GRADIENT = 6.0
DEFAULT_PATHS = 8
DEFAULT_LR_TOLERANCE = 1

#: ``sgm``: aggregations of the cost volume before the semi-global one (None: none).
AGGREGATIONS = ("cross", "cross-both")
#: The cross regions: the best measured for ``"cross-both"`` on the development scenes
#: (``scripts/eval_stages.py``; ADCensus's 34, 20 and 4 rounds lose on the 2014 scenes;
#: ``"cross"``, the left view's regions alone, did best at 7 and 15).
DEFAULT_CROSS_LIMIT = 5
DEFAULT_CROSS_TAU = 10
DEFAULT_CROSS_ITERATIONS = 1

#: ``sgm``: the spacing of the census window's samples (1: every pixel).
DEFAULT_CENSUS_STEP = 1

#: ``sgm``: the Gaussian smoothing (sigma, pixels) of the intensity before the census
#: transform (0: none; :mod:`dcstereo.costs.smoothing`).
DEFAULT_CENSUS_SMOOTHING = 0.0
#: ``sgm``: the largest ``census_smoothing`` (pixels; the weights then reach 16 pixels).
MAX_CENSUS_SMOOTHING = 4.0

#: ``sgm``: the photometric alignments of the right view before the colour term (None: none).
PHOTOMETRIC = ("matched",)

#: ``sgm``: how the right view's rows are moved onto the left's before the costs (None:
#: not at all; ``"estimated"``: by the field :mod:`dcstereo.costs.row_offsets` measures).
ROW_ALIGNMENTS = ("estimated",)

#: ``sgm``: how the pixels near the map's depth edges are decided again after the median
#: (None: not at all; ``"support-weights"``: by adaptive support weights,
#: :mod:`dcstereo.refine.edges`).
EDGES = ("support-weights",)

#: ``sgm``: the largest census window (its bits, one per pixel but the centre, fill 64).
MAX_CENSUS_BITS = 64

#: ``subpixel``: the fits of :func:`dcstereo.refine.subpixel.refine_subpixel`.
SUBPIXEL_FITS = ("equiangular", "parabola")

#: ``median="weighted"``: the median weighted by the left image's colours and the distance
#: (:func:`dcstereo.refine.weighted_median.weighted_median_filter`) instead of a plain one.
WEIGHTED_MEDIAN = "weighted"

#: ``median="weighted-planes"``: the weighted median, then a plane through each pixel's
#: window of estimates within a pixel of its own
#: (:func:`dcstereo.refine.local_planes.local_plane_filter`).
WEIGHTED_PLANES = "weighted-planes"

#: The medians ``median`` may name instead of a window side.
NAMED_MEDIANS = (WEIGHTED_MEDIAN, WEIGHTED_PLANES)

#: ``median``: the largest window of :func:`dcstereo.refine.postfilter.median_filter`.
MAX_MEDIAN = 15


_DC = ("dc", "dc-linear")

#: The methods' own parameters (fields of :class:`MatchParams`) and the methods that read
#: each. Given to any other method (a value other than the default), they are refused:
#: an option a method does not read would change nothing, silently.
METHOD_OPTIONS = {
    "occlusion_cost": ("dc", "dc-linear", "dsi5", "dsi3", "dsi3-gcp", "redert"),
    "slant_cost": ("dsi5", *_DC, "redert"),
    "ser_min": _DC,
    "vs_max": _DC,
    "vs_relative": _DC,
    "feature_floor": _DC,
    "uniqueness": _DC,
    "edge_guard": _DC,
    "lr_check": _DC,
    "max_candidates": _DC,
    "gcp_uniqueness": ("dsi3-gcp",),
    "gcp_variance_floor": ("dsi3-gcp",),
    "orientations": ("redert",),
    "orientation_cost": ("redert",),
    "occlusion_discount": ("redert",),
    "occlusion_discount_pixels": ("redert",),
    "census_window": SGM_METHODS,
    "ad_truncation": SGM_METHODS,
    "p1": SGM_METHODS,
    "p2": SGM_METHODS,
    "p2_gradient": SGM_METHODS,
    "paths": SGM_METHODS,
    "lr_tolerance": SGM_METHODS,
    "planes": ("sgm",),
    "aggregation": SGM_METHODS,
    "cross_limit": SGM_METHODS,
    "cross_tau": SGM_METHODS,
    "cross_iterations": SGM_METHODS,
    "census_step": SGM_METHODS,
    "census_smoothing": SGM_METHODS,
    "photometric": ("sgm",),
    "row_alignment": ("sgm",),
    "edges": ("sgm",),
}


#: Suffix of a method name that runs it with ``cost="bt"`` (``"dsi5+bt"``) in the tools
#: that compare methods (:mod:`dcstereo.evaluation`).
BT_SUFFIX = "+bt"


def base_method(method: str) -> str:
    """Return ``method`` without :data:`BT_SUFFIX`."""
    return method.removesuffix(BT_SUFFIX)


def options_for(method: str, options: dict) -> dict:
    """Return ``options`` without the :data:`METHOD_OPTIONS` that ``method`` does not read.

    For the tools that run several methods with one set of options (``ser_min`` goes to
    ``dc`` and ``dc-linear``, not to ``dsi3``); ``method`` may carry a ``+bt`` suffix, and
    OpenCV's methods read none.
    """
    base = base_method(method)
    return {
        name: value
        for name, value in options.items()
        if name not in METHOD_OPTIONS or base in METHOD_OPTIONS[name]
    }


def check_method_options(names, methods, label=str) -> None:
    """Raise ``ValueError`` for an option of ``names`` that none of ``methods`` reads.

    ``names``: keyword arguments of :func:`dcstereo.match` (those outside
    :data:`METHOD_OPTIONS` are not checked); ``methods``: method names, with or without a
    ``+bt`` suffix (others, OpenCV's, read none); ``label``: how the message names an
    option (the command line: by its flag).
    """
    bases = [base_method(method) for method in methods]
    for name in names:
        readers = METHOD_OPTIONS.get(name)
        if readers is None or any(base in readers for base in bases):
            continue
        if len(bases) == 1:
            fixed = FIXED_OPTIONS.get(bases[0], {})
            if name in fixed:
                raise ValueError(
                    f"{label(name)} is fixed in {methods[0]}, which always runs its stages "
                    f"({name}={fixed[name]!r}); another choice of stages is sgm with them named"
                )
            raise ValueError(
                f"{label(name)} is read only by {', '.join(readers)}, not by {methods[0]}"
            )
        raise ValueError(
            f"{label(name)} is read only by {', '.join(readers)}, none of the methods run "
            f"({', '.join(methods)})"
        )


def check_median(value, name: str = "median") -> int | str:
    """Return a median post-filter: 0 (off), an odd side 3 to :data:`MAX_MEDIAN`, or a name.

    ``"weighted"`` (:data:`WEIGHTED_MEDIAN`): the median weighted by the left image's colours
    (:mod:`dcstereo.refine.weighted_median`); ``"weighted-planes"`` (:data:`WEIGHTED_PLANES`):
    that median, then a local plane per pixel (:mod:`dcstereo.refine.local_planes`).
    """
    names = ", ".join(repr(n) for n in NAMED_MEDIANS[:-1]) + f" or {NAMED_MEDIANS[-1]!r}"
    if isinstance(value, str) and value in NAMED_MEDIANS:
        return value
    if isinstance(value, np.integer):
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int):
        raise TypeError(f"{name} must be an integer, {names}, got {value!r}")
    if value != 0 and not (3 <= value <= MAX_MEDIAN and value % 2 == 1):
        raise ValueError(
            f"{name} must be 0 (off) or an odd integer from 3 to {MAX_MEDIAN}, got {value}"
            f" (or {names})"
        )
    return value


#: ``redert``: the surface orientations (disparity slopes, px/px) of the DP states.
DEFAULT_ORIENTATIONS = (-0.5, -0.25, -0.125, 0.0, 0.125, 0.25, 0.5)
#: ``redert``: cost of a change of orientation between neighbouring matched pixels, in
#: the units of ``occlusion_cost``.
DEFAULT_ORIENTATION_COST = 0.5
#: ``redert``: the fraction of ``occlusion_cost`` taken off the pixels of a run of
#: occlusions after its first (a jump between surfaces costs less than its pixels apart).
DEFAULT_OCCLUSION_DISCOUNT = 0.2
#: ``redert``: how many pixels of a run after its first get the discount.
DEFAULT_OCCLUSION_DISCOUNT_PIXELS = 5
#: ``redert``: the largest ``occlusion_discount_pixels`` (the DP keeps a state per pixel).
MAX_OCCLUSION_DISCOUNT_PIXELS = 64


@dataclass(frozen=True)
class MatchParams:
    """Parameters of one matching run.

    ``sgm-accurate`` reads ``sgm``'s options but four: it always runs the stages
    ``photometric="matched"``, ``planes=True``, ``row_alignment="estimated"`` and
    ``edges="support-weights"`` (:data:`FIXED_OPTIONS`; another value is refused), and its
    ``median`` is ``"weighted-planes"`` unless given.

    A method's own parameter (:data:`METHOD_OPTIONS`) given a value other than its default
    for a method that does not read it is refused (``ValueError``).

    Parameters
    ----------
    max_disparity, min_disparity : int
        Inclusive search range, in pixels: a left pixel ``x`` may match right pixels
        ``x - max_disparity .. x - min_disparity``.
    method : str
        One of :data:`METHODS`.
    window : int
        Odd side ``W`` of the square SAD window of eq. 4, at most :data:`MAX_WINDOW` (725;
        :data:`MAX_BT_WINDOW`, 513, with ``cost="bt"``).
    occlusion_cost : float
        ``C_occ`` of eq. 5 per occluded pixel, in the units of the per-pixel absolute
        difference on the 0..255 intensity scale (the window cost is the *mean* absolute
        difference), so one value means the same thing for every window size.
    fill : bool
        Fill pixels without an estimate with the background disparity (see
        :func:`dcstereo.fill_occlusions`).
    slant_cost : float or None
        Extra cost of each d or e step of the five-step model (eq. 5), in the units of
        ``occlusion_cost``; not in the paper, whose d and e steps cost only the
        mismatch of the cells they cross, so that the path drifts through flat areas and
        ramps across true occlusions for free. None: the method's default,
        :data:`DEFAULT_SLANT_COST` (0, the paper's model) for ``dsi5`` and
        :data:`DEFAULT_DC_SLANT_COST` for the fill DP of ``dc`` (and of ``dc-linear``,
        which runs it at the two ends of each scanline). From ``occlusion_cost`` up, a d
        or e step never beats an occlusion plus a match, and the model is the three-step
        one. Not read by ``dsi3``, ``dsi3-gcp`` and ``block``. ``redert``: the cost of
        each disparity step of a slanted segment (None:
        ``dcstereo.methods.redert.DEFAULT_REDERT_SLANT_COST``).
    ser_min : float
        ``dc`` methods: smallest signal-to-error ratio (eq. 2) of a reliable feature pair,
        ``(var_L + var_R) / sum_window (I_L - I_R)^2``.
    vs_max : float
        ``dc`` methods: largest variance dissimilarity (eq. 3) of a reliable pair.
    vs_relative : bool
        Use the scale-free ``|var_L - var_R| / (var_L + var_R)`` (in ``[0, 1]``) instead of
        the paper's ``|var_L - var_R|`` (gray levels squared).
    feature_floor : float
        Candidates stop at this window variance (gray levels squared): flatter pixels are
        never tried as features. (Pixels within ``window // 2`` of the left or right image
        edge are never candidates either, on either side: their window statistics would
        come from replicated padding.)
    max_candidates : int
        Candidates tried per interval before giving up on it (not counting those an
        enclosing interval already rejected for good); 0 tries every pixel above the floor.
    lr_check : bool
        Also require the right pixel of a candidate pair to choose the same left pixel when
        block-matched back inside the interval (a left-right consistency test; not in the
        paper, which relies on SER and VS alone). Off by default: with ``uniqueness`` and
        ``edge_guard`` on it changes no score on the development scenes by more than 0.01,
        and it costs a few per cent of ``dc``'s time (``docs/guide/methods.md``).
    uniqueness : float
        ``dc`` methods, not in the paper: a uniqueness test (0 disables it). A candidate's
        match must be its least window cost over the whole disparity band (the ordering
        constraint may reject it, never move it), and the second-least cost, over the
        disparities at least two away from the match, must be at least ``uniqueness``
        times the cost of the match. Rejects the ambiguous matches that SER and VS let
        through: horizontal edges (high variance, no texture along the scanline) and
        repeated texture.
    edge_guard : int or None
        ``dc`` methods, not in the paper: a discontinuity guard. The two windows
        ``edge_guard`` columns left and right of a candidate must each block-match (over
        the whole band) within one disparity of the candidate's match, with a
        uniqueness ratio of at least ``uniqueness``; near a depth discontinuity one of
        them lies on the other surface, or on a flat side whose match is ambiguous, which
        is where the window fattens the foreground and most accepted pairs were wrong.
        None: ``window // 2 + 1``, the nearest side windows that leave out the candidate's
        own column; 0 disables the guard.
    cost : str
        The per-pixel dissimilarity summed over the ``W x W`` window: ``"sad"`` (default,
        eq. 4, the absolute difference) or ``"bt"``, the sampling-insensitive
        dissimilarity of Birchfield and Tomasi: the distance of each pixel's value to the
        range of the other image's linear interpolation over half a pixel on either side
        of its partner, the least of the two directions (see
        ``dcstereo.costs.window.row_costs_bt``). Same units (gray levels of mean
        dissimilarity), same edge handling. Every method but ``redert``, whose window is
        sheared, takes both.
    gcp_uniqueness : float
        ``dsi3-gcp`` only: a ground control point's window cost must be its least over
        the disparity band, and the second-least cost (over the disparities at least two
        away) at least ``gcp_uniqueness`` times it (the ratio test of ``uniqueness``);
        0 disables the test. Default :data:`DEFAULT_GCP_UNIQUENESS`.
    gcp_variance_floor : float
        ``dsi3-gcp`` only: least window variance (gray levels squared) of a control point's
        left pixel (textured areas only). Default :data:`DEFAULT_GCP_VARIANCE_FLOOR`.
        A control point must also be left-right consistent (its right pixel's least
        cost over the band is with this left pixel and no other), lie at least
        ``window // 2`` from the image edges in both views, and the points kept on a row
        are the longest subset strictly increasing in both ``x_left`` and ``x_right``
        (the ordering constraint). The three-step DP is forced through them.
    subpixel : str or None
        None (default): whole-pixel disparities (and the e steps' half pixels).
        ``"equiangular"`` or ``"parabola"``: refined to a fraction of a pixel by
        :func:`dcstereo.refine.subpixel.refine_subpixel` before ``fill``, so the filled pixels
        take their neighbours' refined values.
    median : int or str
        0 (default): no post-filter. An odd side from 3 to :data:`MAX_MEDIAN`: every
        estimate but the feature pairs' takes the median of the estimates in that square
        around it (:func:`dcstereo.refine.postfilter.median_filter`), after ``subpixel`` and
        before ``fill``. ``"weighted"``: the median of a 9 x 9 window weighted by the left
        image's colours and the distance
        (:func:`dcstereo.refine.weighted_median.weighted_median_filter`): depth edges stay on
        the colour edges. ``"weighted-planes"``: that median, then each estimate the value
        of a plane fitted to its window's estimates within a pixel of it, weighted alike
        (:func:`dcstereo.refine.local_planes.local_plane_filter`): slanted surfaces lose
        the median's steps.
    orientations : tuple of float
        ``redert`` only: the surface orientations of the DP states, as disparity slopes
        (pixels of disparity per pixel), each one of ``0, +-1/16, +-1/8, +-1/4, +-1/2,
        +-1``, no repeats; default :data:`DEFAULT_ORIENTATIONS`. The matching window is sheared by
        the slope, and a surface of slope ``+-1/L`` runs between integer-disparity
        nodes ``L`` pixels apart (see :mod:`dcstereo.methods.redert`).
    orientation_cost : float
        ``redert`` only: cost of a change of orientation between neighbouring matched
        pixels, in the units of ``occlusion_cost``; default
        :data:`DEFAULT_ORIENTATION_COST`.
    occlusion_discount : float
        ``redert`` only, in ``[0, 1)``: the fraction of ``occlusion_cost`` taken off the
        pixels of a run of occlusions (consecutive occluded left and right pixels between
        two matches, as at a jump between surfaces) after the run's first pixel, for
        ``occlusion_discount_pixels`` of them; the first pixel and those beyond cost
        ``occlusion_cost``. A run that begins at the scanline's start gets no discount.
        Default :data:`DEFAULT_OCCLUSION_DISCOUNT`; 0 charges every occluded pixel alike,
        as the other methods do.
    occlusion_discount_pixels : int
        ``redert`` only: how many pixels of a run after its first get
        ``occlusion_discount`` (0 to :data:`MAX_OCCLUSION_DISCOUNT_PIXELS`; 0: none).
        Default :data:`DEFAULT_OCCLUSION_DISCOUNT_PIXELS`: a run of ``n`` pixels costs
        ``occlusion_cost * (n - occlusion_discount * min(n - 1, 5))``.
    planes : bool or None
        ``sgm`` only, off (None: the method's default) by default: after the left-right
        check, a robust plane per
        superpixel of the left image gives its value to the mismatched pixels and to the
        unsure estimates far from it (:func:`dcstereo.refine.planes.refine_planes`).
    aggregation : str or None
        ``sgm`` only, off (None) by default: a stage between the costs and the semi-global
        aggregation. ``"cross"``: the costs averaged over cross-based support regions of the
        left view (ADCensus; ``cross_limit``, ``cross_tau``, ``cross_iterations``, see
        :mod:`dcstereo.aggregate.cross`); ``"cross-both"``: over the regions the two views
        share at each disparity (the shorter of the left and the right pixel's arms, as
        ADCensus combines them). The guided filter of the slices (CostFilter) and
        MGM's paths were tried and lost (commit 08d52ae holds them).
    census_step : int
        ``sgm`` only: the spacing of the census window's samples (1, the default: every
        pixel; 2: a sparse census twice as wide for the same bits).
    census_smoothing : float
        ``sgm`` only: the sigma, in pixels, of a Gaussian smoothing of each view's
        intensity before the census transform (0, the default: none; at most
        :data:`MAX_CENSUS_SMOOTHING`). Against the noise of camera images in weakly
        textured places (KITTI's road and walls: 1.2 helps); sharp images lose their
        finest texture by it (:mod:`dcstereo.costs.smoothing`).
    photometric : str or None
        ``sgm`` with ``cost="census-ad"`` only, off (None) by default. ``"matched"``: before
        the colour term, each channel of the right view is mapped onto the left's levels
        through the histograms of the pixels a coarse pass matched (census alone, four
        times smaller each way), so that a change of gain, offset or gamma between the
        views costs the colour term little (:mod:`dcstereo.costs.photometric`).
    row_alignment : str or None
        ``sgm`` only, off (None) by default. ``"estimated"``: for a pair whose rectification
        is a little off, the right view's rows are moved onto the left's before the costs,
        by a smooth field of vertical offsets measured from patches matched around a
        coarse pass's disparities (:mod:`dcstereo.costs.row_offsets`); a pair whose field
        stays under :data:`~dcstereo.costs.row_offsets.MIN_OFFSET` rows everywhere is left
        as it is.
    edges : str or None
        ``sgm`` only, off (None) by default. ``"support-weights"``: after the median, each
        pixel near a depth edge of the map compares its value with the farther values
        just past the jumps around it by an adaptive-support-weight matching cost and takes
        one that is clearly cheaper, against the foreground's windows pulling it over the
        background (:mod:`dcstereo.refine.edges`).
    """

    max_disparity: int
    min_disparity: int = 0
    method: str = DEFAULT_METHOD
    window: int | None = None
    occlusion_cost: float = DEFAULT_OCCLUSION_COST
    fill: bool | None = None
    slant_cost: float | None = None
    ser_min: float = DEFAULT_SER_MIN
    vs_max: float = DEFAULT_VS_MAX
    vs_relative: bool = True
    feature_floor: float = DEFAULT_FEATURE_FLOOR
    max_candidates: int = 0
    lr_check: bool = False
    uniqueness: float = DEFAULT_UNIQUENESS
    edge_guard: int | None = None
    orientations: tuple[float, ...] = DEFAULT_ORIENTATIONS
    orientation_cost: float = DEFAULT_ORIENTATION_COST
    occlusion_discount: float = DEFAULT_OCCLUSION_DISCOUNT
    occlusion_discount_pixels: int = DEFAULT_OCCLUSION_DISCOUNT_PIXELS
    cost: str | None = None
    gcp_uniqueness: float = DEFAULT_GCP_UNIQUENESS
    gcp_variance_floor: float = DEFAULT_GCP_VARIANCE_FLOOR
    subpixel: str | None = None
    median: int | str | None = None
    census_window: tuple[int, int] = DEFAULT_CENSUS_WINDOW
    ad_truncation: int = DEFAULT_AD_TRUNCATION
    p1: int = DEFAULT_P1
    p2: int = DEFAULT_P2
    p2_gradient: float = DEFAULT_P2_GRADIENT
    paths: int = DEFAULT_PATHS
    lr_tolerance: int | None = DEFAULT_LR_TOLERANCE
    planes: bool | None = None
    aggregation: str | None = None
    cross_limit: int = DEFAULT_CROSS_LIMIT
    cross_tau: int = DEFAULT_CROSS_TAU
    cross_iterations: int = DEFAULT_CROSS_ITERATIONS
    census_step: int = DEFAULT_CENSUS_STEP
    census_smoothing: float = DEFAULT_CENSUS_SMOOTHING
    photometric: str | None = None
    row_alignment: str | None = None
    edges: str | None = None

    def __post_init__(self):
        from dcstereo import _method_checks  # it reads this module's tables

        for field in fields(self):  # numpy scalars (np.int64(4), np.True_): the Python value
            value = getattr(self, field.name)
            if isinstance(value, np.generic):
                object.__setattr__(self, field.name, value.item())
        if self.method not in METHODS:
            raise ValueError(f"unknown method {self.method!r}; choose one of {', '.join(METHODS)}")
        defaults = METHOD_DEFAULTS.get(self.method, METHOD_DEFAULTS[None])
        off = isinstance(self.subpixel, (bool, str)) and self.subpixel in SUBPIXEL_OFF
        for name, value in defaults.items():
            if getattr(self, name) is None:
                object.__setattr__(self, name, value)
        if off:
            object.__setattr__(self, "subpixel", None)
        fixed = FIXED_OPTIONS.get(self.method, {})
        for name, value in fixed.items():
            given = getattr(self, name)
            if given != value and given != self.__dataclass_fields__[name].default:
                raise ValueError(
                    f"{name}={given!r}: {self.method} always runs its stages ({name}="
                    f"{value!r}); another choice of stages is method='sgm' with them named"
                )
            object.__setattr__(self, name, value)
        for name in ("fill", "vs_relative", "lr_check", "planes"):
            value = getattr(self, name)
            if not isinstance(value, bool):
                raise TypeError(f"{name} must be True or False, got {value!r}")
        for name in ("max_disparity", "min_disparity", "window", "max_candidates"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int):
                if isinstance(value, float) and value.is_integer():
                    object.__setattr__(self, name, int(value))
                else:
                    raise TypeError(f"{name} must be an integer, got {value!r}")
        if self.min_disparity > self.max_disparity:
            raise ValueError(
                f"min_disparity={self.min_disparity} is larger than "
                f"max_disparity={self.max_disparity}"
            )
        if self.window < 1 or self.window % 2 == 0:
            raise ValueError(f"window must be a positive odd integer, got {self.window}")
        if self.window > MAX_WINDOW:
            raise ValueError(
                f"window={self.window} is larger than {MAX_WINDOW}, the largest whose window "
                "sums fit the kernels' 32-bit integers"
            )
        cost = self.occlusion_cost
        if isinstance(cost, bool) or not isinstance(cost, (int, float)) or not math.isfinite(cost):
            raise ValueError(f"occlusion_cost must be a finite number, got {cost!r}")
        if cost <= 0:
            raise ValueError(f"occlusion_cost must be positive, got {cost}")
        if self.cost not in COSTS:
            raise ValueError(f"unknown cost {self.cost!r}; choose one of {', '.join(COSTS)}")
        accepted = costs_of(self.method)
        if self.cost not in accepted:
            raise ValueError(
                f"cost={self.cost!r} is not supported by {self.method} "
                f"(it takes {', '.join(repr(c) for c in accepted)})"
            )
        if self.subpixel is not None and self.subpixel not in SUBPIXEL_FITS:
            raise ValueError(
                f"subpixel must be None (the method's default), 'none' (off) or one of "
                f"{', '.join(SUBPIXEL_FITS)}, got {self.subpixel!r}"
            )
        object.__setattr__(self, "median", check_median(self.median))
        if self.cost == "bt" and self.window > MAX_BT_WINDOW:
            raise ValueError(
                f"window={self.window} is larger than {MAX_BT_WINDOW}, the largest whose "
                "Birchfield-Tomasi window sums fit the kernels' 32-bit integers"
            )
        _method_checks.check_semi_global(self)
        for name in (
            "ser_min",
            "vs_max",
            "feature_floor",
            "slant_cost",
            "uniqueness",
            "gcp_uniqueness",
            "gcp_variance_floor",
        ):
            value = getattr(self, name)
            if value is None and name == "slant_cost":
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or value < 0:
                raise ValueError(f"{name} must be a non-negative number, got {value!r}")
            if math.isnan(value):
                raise ValueError(f"{name} must be a non-negative number, got {value!r}")
        if self.max_candidates < 0:
            raise ValueError(
                f"max_candidates must be 0 (no limit) or positive, got {self.max_candidates}"
            )
        guard = self.edge_guard
        if guard is not None:
            if isinstance(guard, bool) or not isinstance(guard, int):
                if isinstance(guard, float) and guard.is_integer():
                    object.__setattr__(self, "edge_guard", int(guard))
                else:
                    raise TypeError(f"edge_guard must be an integer or None, got {guard!r}")
            if self.edge_guard < 0:
                raise ValueError(
                    f"edge_guard must be None, 0 (no guard) or positive, got {self.edge_guard}"
                )
        _method_checks.check_redert(self)
        given = [  # a value other than the option's default and the method's
            field.name
            for field in fields(self)
            if field.name in METHOD_OPTIONS
            and field.name not in fixed
            and getattr(self, field.name) != field.default
            and getattr(self, field.name) != defaults.get(field.name, field.default)
        ]
        check_method_options(given, [self.method])

    @property
    def effective_slant_cost(self) -> float:
        """``slant_cost``, or the method's default when it is None."""
        if self.slant_cost is not None:
            return float(self.slant_cost)
        return DEFAULT_DC_SLANT_COST if self.method in ("dc", "dc-linear") else DEFAULT_SLANT_COST

    @property
    def effective_edge_guard(self) -> int:
        """``edge_guard``, or ``window // 2 + 1`` when it is None."""
        return self.window // 2 + 1 if self.edge_guard is None else self.edge_guard

    @property
    def num_disparities(self) -> int:
        """Number of disparities searched (``max - min + 1``)."""
        return self.max_disparity - self.min_disparity + 1

    def check_image_size(self, height: int, width: int) -> None:
        """Raise ``ValueError`` when the range or the window does not fit a (H, W) image."""
        if self.max_disparity >= width:
            raise ValueError(
                f"max_disparity={self.max_disparity} does not fit an image {width} pixels wide "
                f"(it must be at most {width - 1})"
            )
        if self.min_disparity <= -width:
            raise ValueError(
                f"min_disparity={self.min_disparity} does not fit an image {width} pixels wide "
                f"(it must be at least {-(width - 1)})"
            )
        if self.window > min(height, width):
            raise ValueError(
                f"window={self.window} is larger than the image ({height} x {width} pixels)"
            )
