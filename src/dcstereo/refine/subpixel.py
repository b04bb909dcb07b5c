"""Sub-pixel disparity: a fit through the matching cost around each integer estimate.

The matchers give integer disparities (and half pixels from the five-step model's e
steps): on a slanted surface the depth then comes in layers, one per pixel of disparity.
:func:`refine_subpixel` moves each integer estimate ``d`` by the offset where a curve
through the window costs at ``d - 1``, ``d`` and ``d + 1`` is least:

* ``"equiangular"`` (default): two lines of opposite slopes, the fit Shimizu and Okutomi
  (2001) found suited to absolute differences (the SAD of eq. 4), with less of the
  parabola's pull toward whole pixels;
* ``"parabola"``: the three-point parabola, as OpenCV's block matchers use.

The cost is the run's, with the run's window: eq. 4's windowed SAD of the matching
signal, or the Birchfield-Tomasi dissimilarity summed over the window (``cost="bt"``;
the values the matcher used). Pixels keep their value where there is nothing to fit: no estimate,
filled, a half-pixel value, ``d`` at an end of the searched range, or a ``d`` whose cost
is not the least of the three (the DP's smoothness chose it over its neighbours).

``dcstereo.match(..., subpixel="equiangular")`` runs it inside the match, before ``fill``.
"""

from dataclasses import replace

import numpy as np

from dcstereo.params import SGM_METHODS
from dcstereo.params import SUBPIXEL_FITS as FITS
from dcstereo.refine import _subpixel as subpixel_kernels
from dcstereo.result import FLAG_FILLED, DisparityResult, check_result_pair
from dcstereo.signal import padded_signal


def refine_subpixel(
    result: DisparityResult, left, right, *, fit: str = "equiangular"
) -> DisparityResult:
    """Return ``result`` with sub-pixel disparities (flags and features unchanged).

    Parameters
    ----------
    result : DisparityResult
        From :func:`dcstereo.match` on ``left`` and ``right``.
    left, right : ndarray
        The pair that was matched.
    fit : {"equiangular", "parabola"}
        The curve through the three costs (see the module's text).

    Returns
    -------
    DisparityResult
        Each refined pixel moved by less than half a pixel.

    Raises
    ------
    ValueError
        For a result of ``sgm``, whose fit runs through its own aggregated costs inside the
        match (``dcstereo.match(..., subpixel=fit)``), not through window costs.
    """
    if fit not in FITS:
        raise ValueError(f"fit must be one of {', '.join(FITS)}, got {fit!r}")
    left, right = check_result_pair(result, left, right)
    params = result.params
    if params.method in SGM_METHODS:
        raise ValueError(
            f"{params.method} fits its own aggregated costs: match with subpixel="
            f"{fit!r} (dcstereo run --subpixel {fit}) instead of refining its result"
        )
    radius = params.window // 2
    d = result.disparity
    with np.errstate(invalid="ignore"):
        wanted = np.isfinite(d) & (np.floor(d) == d) & ((result.flags & FLAG_FILLED) == 0)
    out = d.copy()
    subpixel_kernels.refine_rows(
        padded_signal(left, radius),
        padded_signal(right, radius),
        d,
        wanted,
        params.min_disparity,
        params.max_disparity,
        radius,
        FITS.index(fit),
        out,
        params.cost == "bt",
    )
    return replace(result, disparity=out)
