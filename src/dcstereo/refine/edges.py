"""Depth edges re-decided by adaptive support weights: the background a fattened edge took.

A matcher that sums its costs over windows (the census, the box, the paths) pulls a
foreground surface a pixel or two over the background beside it: the windows of those
background pixels hold the foreground's stronger texture. The left-right check does not
see it where the background is visible in both views, to the right of, above and below a
foreground object, and a median guided by the colours keeps it where the colours change a
little inside the edge. On the development scenes most of the errors left by the most
accurate pipeline are of that kind.

Here each pixel near a jump of the map (its 7 x 7 window spans more than 2 pixels) looks
along five directions (up, down, right and the two right diagonals; to its left lie the
occluded pixels) for the first jump within 3 pixels, before the left image's colour
changes by more than 20 in a channel, and takes the value past it as a candidate where
that value is farther than its own and an estimate of the matcher's own (its pixel carries
no flag). The pixel then compares its own value with the candidates by the cost of Yoon
and Kweon's adaptive support weights (*Adaptive Support-Weight Approach for Correspondence
Search*, PAMI 2006) over a 15 x 15 window, each pixel of the window weighted by its colour
likeness to the centre in both views and its distance, so that the window counts the
centre's own surface: ADCensus's cost (Mei et al. 2011) of a 5 x 5 census and the colours,
``2 - exp(-h / 10) - exp(-c / 10)``. A candidate 10 % cheaper than the pixel's own value
wins. It runs after the median stage (``dcstereo.match(..., edges="support-weights")``,
``sgm``; :func:`edge_refinement` for any result).
"""

from dataclasses import replace

import numba as nb
import numpy as np

from dcstereo.costs.census import census_transform
from dcstereo.refine import _edges as kernels
from dcstereo.refine.postfilter import _inside
from dcstereo.refine.weighted_median import kernel_guide
from dcstereo.result import DisparityResult, check_result_pair
from dcstereo.signal import colour_channels

__all__ = ["edge_refinement", "refine_edges", "support_weight_tables"]

#: Half the side of the window whose span marks a pixel near a jump (7 x 7).
ZONE = 3
#: A window spanning more than this (pixels) holds a jump.
JUMP = 2.0
#: How far (pixels) a pixel looks along a direction for a jump.
REACH = 3
#: A colour change larger than this (0..255, a channel) ends the look: the surface past it
#: is another object's.
COLOUR_LIMIT = 20
#: Half the side of the support window (15 x 15).
RADIUS = 7
#: The colour difference (0..255) and the distance (pixels) that divide a weight by e.
COLOUR_SCALE = 10.0
SPACE_SCALE = 10.0
#: The census window's half side (5 x 5) and the Hamming distance that brings its term
#: to 1 - 1/e.
CENSUS_RADIUS = 2
CENSUS_SCALE = 10.0
#: The channels' summed absolute difference is truncated here, then divided by 3; that
#: mean difference brings the colour term to 1 - 1/e at ``COLOUR_COST_SCALE``.
TRUNCATION = 40.0
COLOUR_COST_SCALE = 10.0
#: A candidate must cost less than ``1 - MARGIN`` times the pixel's own value.
MARGIN = 0.1


def support_weight_tables(radius: int = RADIUS) -> tuple[np.ndarray, np.ndarray]:
    """Return the weight tables: by colour difference (256) and by offset (square), float64.

    ``colour[g] = exp(-g / COLOUR_SCALE)``, ``space[dy + radius, dx + radius] =
    exp(-hypot(dy, dx) / SPACE_SCALE)``.

    >>> colour, space = support_weight_tables(1)
    >>> round(float(colour[10]), 4), round(float(space[0, 1]), 4)
    (0.3679, 0.9048)
    """
    colour = np.exp(-np.arange(256, dtype=np.float64) / COLOUR_SCALE)
    offsets = np.arange(-radius, radius + 1, dtype=np.float64)
    space = np.exp(-np.hypot(offsets[:, None], offsets[None, :]) / SPACE_SCALE)
    return colour, space


def edge_refinement(
    result: DisparityResult, left: np.ndarray, right: np.ndarray
) -> DisparityResult:
    """Return ``result`` with the pixels near its depth edges re-decided (module text).

    Parameters
    ----------
    result : DisparityResult
        The map to refine, best after the median stage; its flags mark the pixels whose
        values may not be taken (any flag: occluded, filled, mismatched...).
    left, right : ndarray
        The pair the map belongs to (gray or colour, any of the library's input types), of
        the map's shape. ``sgm`` with ``photometric`` or ``row_alignment`` compares a right
        view changed by them; :func:`refine_edges` takes those channels
        (:func:`dcstereo.methods.sgm.sgm_views`).

    Returns
    -------
    DisparityResult
        The same flags; a pixel that took a candidate has the candidate's value, limited
        as the medians limit theirs to the disparities its pixel can have.

    Examples
    --------
    A square in front of a wall, each of one colour and a faint texture, the square's
    estimates fattened by two pixels to its right:

    >>> import numpy as np
    >>> from dcstereo.params import MatchParams
    >>> from dcstereo.refine.edges import edge_refinement
    >>> from dcstereo.result import DisparityResult, check_result_pair
    >>> rng = np.random.default_rng(1)
    >>> wall = rng.integers(90, 110, (40, 80)).astype(np.uint8)
    >>> left, truth = np.roll(wall, 4, axis=1), np.full((40, 80), 4, np.float32)
    >>> square = rng.integers(190, 210, (16, 16)).astype(np.uint8)
    >>> left[12:28, 30:46], truth[12:28, 30:46] = square, 12
    >>> right = wall.copy()
    >>> right[12:28, 18:34] = square
    >>> fat = truth.copy()
    >>> fat[12:28, 46:48] = 12
    >>> params = MatchParams(max_disparity=16, method="sgm")
    >>> result = DisparityResult(fat, np.zeros(fat.shape, np.uint8), params, np.zeros(40))
    >>> bool(np.array_equal(edge_refinement(result, left, right).disparity, truth))
    True
    """
    left, right = check_result_pair(result, left, right)
    guide_l, guide_r = colour_channels(left, right)
    return refine_edges(result, guide_l, guide_r)


def refine_edges(
    result: DisparityResult, guide_l: np.ndarray, guide_r: np.ndarray
) -> DisparityResult:
    """Return :func:`edge_refinement` of the views' channels.

    ``guide_l``, ``guide_r``: ``(C, H, W)`` arrays of levels 0..255, one or three channels
    each (a gray view counts as three equal ones), of the map's shape, as
    :func:`dcstereo.signal.colour_channels` gives them (any real dtype; the left view's
    levels are rounded to whole ones). For ``sgm``'s own views after ``row_alignment`` and
    ``photometric``: ``refine_edges(result, *dcstereo.methods.sgm.sgm_views(left, right,
    result.params))``. Raises TypeError or ValueError naming the argument.
    """
    if not isinstance(result, DisparityResult):
        raise TypeError(f"result must be a DisparityResult, got {type(result).__name__}")
    shape = result.disparity.shape
    checked = []
    for name, guide in (("guide_l", guide_l), ("guide_r", guide_r)):
        guide = np.asarray(guide)
        if guide.ndim != 3 or guide.shape[0] not in (1, 3) or guide.shape[1:] != shape:
            raise ValueError(
                f"{name} must be (1 or 3, {shape[0]}, {shape[1]}) channels, got shape {guide.shape}"
            )
        if guide.dtype.kind not in "biuf":
            raise TypeError(f"{name} must be a real array, got {guide.dtype}")
        guide = guide.astype(np.float32)
        if not (
            np.isfinite(guide).all() and guide.min(initial=0) >= 0 and guide.max(initial=0) <= 255
        ):
            raise ValueError(f"{name} must hold finite levels 0..255")
        checked.append(guide)
    guide_l = kernel_guide(np.rint(checked[0]).astype(np.int16))
    guide_r = np.ascontiguousarray(kernel_guide(checked[1]), dtype=np.float32)
    pad, padded, space = padded_views(guide_l, guide_r, _census(guide_l), _census(guide_r))
    disparity = np.ascontiguousarray(result.disparity, dtype=np.float32)
    out = np.empty_like(disparity)
    row_low, row_high = np.empty_like(disparity), np.empty_like(disparity)
    kernels.row_extremes(disparity, ZONE, row_low, row_high)
    reachable = np.empty(disparity.shape, dtype=np.bool_)
    kernels.reachable_jumps(disparity, REACH, reachable)
    kernels.edge_rows(
        disparity, np.ascontiguousarray(result.flags), guide_l, *padded, pad, row_low, row_high,
        reachable, ZONE, JUMP, REACH, COLOUR_LIMIT, RADIUS, COLOUR_SCALE, space, TRUNCATION,
        CENSUS_SCALE, COLOUR_COST_SCALE, MARGIN, out, nb.get_num_threads(),
    )  # fmt: skip
    return replace(result, disparity=_inside(out, result))


def padded_views(guide_l, guide_r, codes_l, codes_r, radius: int = RADIUS):
    """Return ``(pad, (left, right, codes_l, codes_r), space)`` as the support cost reads them.

    Each view and code array padded with zeros by ``pad = radius + 2`` columns on the left
    and ``pad + LANES`` on the right (:func:`dcstereo.refine._edges.support_cost` reads
    whole blocks of :data:`~dcstereo.refine._edges.LANES` columns, those outside weighing
    0), and :func:`support_weight_tables`' space weights in float32 (the support cost's
    precision) with their rows padded with zeros to a multiple of ``LANES`` columns.
    """
    pad = radius + 2

    def padded(view):
        widths = [(0, 0)] * (view.ndim - 1) + [(pad, pad + kernels.LANES)]
        return np.ascontiguousarray(np.pad(view, widths))

    _, space = support_weight_tables(radius)
    side = 2 * radius + 1
    blocks = np.zeros((side, -(-side // kernels.LANES) * kernels.LANES), dtype=np.float32)
    blocks[:, :side] = space
    return pad, tuple(padded(v) for v in (guide_l, guide_r, codes_l, codes_r)), blocks


def _census(guide: np.ndarray) -> np.ndarray:
    """Return the :data:`CENSUS_RADIUS` census codes of a guide's mean intensity (float32)."""
    intensity = guide.astype(np.float32, copy=False).mean(axis=0)
    side = 2 * CENSUS_RADIUS + 1
    codes = np.empty(intensity.shape, dtype=np.uint32 if side * side - 1 <= 32 else np.uint64)
    census_transform(np.pad(intensity, CENSUS_RADIUS, mode="edge"), side, side, codes)
    return codes
