"""``redert``: disparity with modelling of occlusion and object orientation [6].

A reconstruction of the estimator of A. Redert, C.-J. Tsai, E. Hendriks and
A. K. Katsaggelos, *Disparity estimation with modeling of occlusion and object
orientation*, SPIE VCIP 1999, the method that Tsai and Katsaggelos compare with in their
Fig. 4. Our sources keep only the labels of its figures; this module says what was
taken from them and what is our choice.

From the figure labels
    * the path is a sequence of nodes ``(x_k, d_k)``: one integer disparity per left pixel;
    * between consecutive nodes sit *half-pixel nodes* ``(d_{k+1/2}, o_{k+1/2})`` carrying a
      disparity and an *orientation*;
    * the matching window ``W`` around ``x_L`` is *mapped into the right image*.

Our choices (the reconstruction)
    * An orientation is a disparity slope ``o`` (pixels of disparity per pixel) from a
      small set (``MatchParams.orientations``, each one of ``0, +-1/16, +-1/8, +-1/4,
      +-1/2, +-1``; default ``-1/2, -1/4, -1/8, 0, 1/8, 1/4, 1/2``). The DP state of a
      node is ``(x, d, o)``.
    * Nodes carry integer disparities. A surface of slope ``o = +-1/L`` runs from node
      ``(x - L, d -+ 1)`` to node ``(x, d)`` in one *segment*; the ``L - 1`` pixels in
      between lie on the line (disparities in multiples of ``1 / steps`` pixel, ``steps``
      the largest ``L`` of the set: eighths by default), and the half-pixel node
      of the labels is this segment with its orientation. Slope 0 is a one-pixel segment
      at constant disparity. So a plane of slope 1/2 is followed node to node, two pixels
      at a time (``d, d + 1/2, d + 1, ...``), with exact matches and no occlusion; with
      integer nodes on every pixel instead, every other pixel of such a plane sits half a
      pixel off its node and the DP prefers occlusions (we tried it).
    * Mapping the window: the left window of side ``W = 2 r + 1`` centred at ``x`` with
      disparity ``d`` and slope ``o`` compares left column ``x + s`` with the right position
      ``x + s - (d + o s)``, ``s = -r..r`` (stretched or compressed by the slant), sampled by
      linear interpolation at ``1 / steps`` pixel (exact integers); the cost is the sum
      of absolute differences over the ``W x W`` window, in the units of the other
      methods (mean absolute difference per pixel, 0..255 gray levels). At ``o = 0`` it
      is eq. 4; a segment costs the sum over its pixels.
    * A change of orientation between consecutive segments costs
      ``MatchParams.orientation_cost``; each disparity step of a slanted segment costs
      ``MatchParams.slant_cost`` (None: :data:`DEFAULT_REDERT_SLANT_COST`). Neither is in
      the labels. Without the slant cost, two orientation changes buy a ramp of any
      length, and in flat areas the path drifts down ramps to wrong disparities (venus
      bad-1.0 nonocc 5.3 % instead of 4.2 %). Both are in the units of the occlusion cost.
      The slant cost stays below the occlusion cost, or steep planes (slope 1/2) are cut
      into occlusions.
    * Occlusions are explicit states: a left pixel without a partner, or a right pixel
      without a partner, costs ``MatchParams.occlusion_cost``, as in ``dsi3``; after an
      occlusion the next match starts a new surface (a diagonal step into any
      orientation, no orientation cost).
    * A run of occlusions between two matches (consecutive left and right occlusions: a
      jump between surfaces) is cheaper than its pixels apart: the pixels after the
      run's first, up to ``MatchParams.occlusion_discount_pixels`` of them (default 5),
      cost ``1 - MatchParams.occlusion_discount`` (default 0.2) times the occlusion
      cost. Not in the labels. Two limits keep slanted planes: a run that begins at the
      scanline's start gets no discount, and the discount stops after 5 pixels. Without
      them the path would skip the start of a slope-1/2 plane (free border pixels, then
      one long, cheap run of right occlusions) as soon as the slant cost exceeds the
      discounted pixel cost. With ``occlusion_discount=0`` (or no discounted pixels) and
      ``orientations=(0,)`` the model is exactly the three-step DP of ``dsi3``.
    * The defaults (slopes above, slant 9, orientation 0.5, discount 0.2 for 5 pixels)
      were chosen on the four development scenes together (``docs/guide/methods.md``).
    * The scanline ends are those of ``dsi3``: a free virtual start where one image has
      consumed nothing, and the path ends when either image's last column is reached;
      pixels left over are ``FLAG_BORDER``.
    * The orientation of each matched pixel is returned on request.

Why the slopes +-1/8 (and eighth-pixel sampling): venus, the development scene with
slanted planes, has horizontal slopes below 1/4 almost everywhere (76 % of its pixels
under 1/48, the rest mostly around 1/32 to 1/8), so with ``0, +-1/4, +-1/2`` it was
matched as by ``dsi3``, with ramps at discontinuities added. Slopes of 1/8 give its
planes fractional disparities (venus bad-0.5 nonocc 10.7 % against 11.5 % with quarter
slopes and 10.9 % for ``dsi3``). What the slopes did not change: most of venus's
bad-1.0 pixels are long streaks shared with ``dsi3``, where a textureless stretch lies
between two surfaces about five disparities apart and the path keeps the wrong disparity
rather than pay two jumps of five occlusions. The run discount makes those jumps cheaper
(a five-pixel run costs 4.2 occlusions instead of 5) without making a single occlusion
cheaper, and venus bad-1.0 nonocc falls from 3.92 % (the same settings without it;
4.01 % with the former defaults) to 3.42 % against 3.85 % for ``dsi3`` (bad-0.5
10.1 % against 10.9 %, MAE 0.380 against 0.412 px); the four-scene
mean bad-1.0 nonocc is 6.39 % (former defaults 6.50 %, ``dsi3`` 6.16 %). The discount
costs teddy and cones a little (9.27 % and 9.05 % against 9.19 % and 8.57 % at the same
other settings) and the mean MAE (0.577 against 0.556 px).

Memory is O(W x D x (orientations + 2 x discounted pixels)) per thread; rows are
independent and run in parallel.
"""

from dataclasses import dataclass

import numpy as np

from dcstereo import _records as records
from dcstereo.methods._pipeline import REFINE, Method, MethodParams, core, option
from dcstereo.params import MatchParams
from dcstereo.result import DisparityResult
from dcstereo.scanline import redert as redert_kernels
from dcstereo.scanline import rows
from dcstereo.signal import SIGNAL_STEPS, check_pair, padded_signal


def redert_cost_scale(window: int, steps: int) -> float:
    """Return the kernel's cost units per gray level of mean absolute difference.

    The kernel compares ``steps * left`` with interpolations of the right image at
    multiples of ``1 / steps`` pixel (exact integers), so its units are ``steps`` times
    those of ``dsi3``.
    """
    return float(steps * SIGNAL_STEPS * window * window)


#: ``redert``'s default ``slant_cost``: per unit of disparity change along a slanted
#: surface, in the units of ``occlusion_cost``.
DEFAULT_REDERT_SLANT_COST = 9.0


def redert_slant_cost(params: MatchParams) -> float:
    """``params.slant_cost``, or :data:`DEFAULT_REDERT_SLANT_COST` when it is None."""
    return DEFAULT_REDERT_SLANT_COST if params.slant_cost is None else float(params.slant_cost)


def orientation_steps(orientations) -> tuple[int, np.ndarray]:
    """Return ``(steps, oq)``: the sampling resolution and the slopes in units of 1/steps.

    ``steps`` is the smallest power of two (1 to 16) that makes every slope (0 or
    ``+-1/L``) a whole multiple of ``1 / steps``; ``oq`` holds the slopes times ``steps``
    as int64, as the kernel wants. A set of ``0, +-1/4, +-1/2`` gives ``steps = 4``.
    """
    slopes = [float(o) for o in orientations]
    steps = 1
    while any(steps * o != round(steps * o) for o in slopes):
        steps *= 2
    return steps, np.array([int(round(steps * o)) for o in slopes], dtype=np.int64)


def match_redert(
    left: np.ndarray, right: np.ndarray, params: MatchParams, *, with_orientation: bool = False
):
    """Estimate disparity with the orientation-and-occlusion DP of Redert et al. [6].

    See the module docstring for what the model is and which parts are reconstructed.
    A left pixel ``x`` matches the right pixel ``x - d``.

    Parameters
    ----------
    left, right : ndarray, shape (H, W) or (H, W, 3|4)
        Rectified pair (any dtype accepted by :func:`dcstereo.match`).
    params : MatchParams
        ``min_disparity``, ``max_disparity``, ``window``, ``occlusion_cost``,
        ``orientations``, ``orientation_cost``, ``slant_cost``, ``occlusion_discount``
        and ``occlusion_discount_pixels`` are used (``fill`` is applied by
        :func:`dcstereo.match`, not here).
    with_orientation : bool
        Also return the orientation map.

    Returns
    -------
    result : DisparityResult
        Integer disparities (float32, NaN where occluded or border), flags
        ``FLAG_OCCLUDED``/``FLAG_BORDER``, the cost of each row's path in gray levels of
        mean absolute difference.
    orientation : ndarray of float32, shape (H, W)
        Only with ``with_orientation``: the disparity slope of each matched pixel's
        half-pixel node (NaN where unmatched).

    Examples
    --------
    >>> import numpy as np
    >>> from dcstereo import MatchParams
    >>> from dcstereo.methods.redert import match_redert
    >>> rng = np.random.default_rng(0)
    >>> right = rng.integers(0, 256, (12, 30), dtype=np.uint8)
    >>> left = np.roll(right, 2, axis=1)
    >>> result = match_redert(left, right, MatchParams(max_disparity=4, method="redert"))
    >>> float(np.nanmedian(result.disparity))
    2.0
    """
    if not isinstance(params, MatchParams):
        raise TypeError(f"params must be a MatchParams, got {type(params).__name__}")
    if params.cost != "sad":
        raise ValueError(f"cost={params.cost!r} is not supported by redert (its window is sheared)")
    left, right = check_pair(left, right)
    params.check_image_size(*left.shape[:2])
    radius = params.window // 2
    left_p = padded_signal(left, radius)
    right_p = padded_signal(right, radius)
    height, width = left.shape[:2]
    out = records.outputs(height, width)
    slopes = np.empty((height, width), dtype=np.float32)
    nchunks = rows.chunk_count(height)
    steps, oq = orientation_steps(params.orientations)
    scale = redert_cost_scale(params.window, steps)
    occlusion = float(np.rint(params.occlusion_cost * scale))
    discount = float(np.rint(params.occlusion_discount * params.occlusion_cost * scale))
    # one state per discounted pixel; without a discount the plain model (one state)
    run_cap = 1 + params.occlusion_discount_pixels if discount > 0 else 1
    model = records.redert_model(
        steps,
        oq,
        occlusion,
        discount,
        run_cap,
        float(np.rint(params.orientation_cost * scale)),
        float(np.rint(redert_slant_cost(params) * scale)),
    )
    dsi = records.dsi(params.min_disparity, params.num_disparities, radius)
    redert_kernels.match_redert_rows(left_p, right_p, dsi, model, nchunks, out, slopes)
    result = DisparityResult(out.disparity, out.flags, params, out.total / scale)
    return (result, slopes) if with_orientation else result


@dataclass(frozen=True, kw_only=True)
class RedertParams(MethodParams):
    """``redert``'s parameters: the costs of occlusion, slant and orientation, the discount.

    Defaults as :class:`~dcstereo.MatchParams`' (and :func:`dcstereo.match`'s).
    """

    METHOD = "redert"
    occlusion_cost: float = option("occlusion_cost")
    slant_cost: float | None = option("slant_cost")
    orientations: tuple[float, ...] = option("orientations")
    orientation_cost: float = option("orientation_cost")
    occlusion_discount: float = option("occlusion_discount")
    occlusion_discount_pixels: int = option("occlusion_discount_pixels")


METHOD = Method(
    "redert",
    (core("redert", match_redert, "sheared costs + DP with orientations"), *REFINE),
    "the DP with occlusion and orientation of Redert et al. [6]",
    params=RedertParams,
)
