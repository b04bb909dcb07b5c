"""How sure the matcher is of each pixel: the margin over the best rival disparity.

:func:`confidence` compares, at every pixel with an estimate ``d``, the window cost of
``d`` (eq. 4, or Birchfield-Tomasi when the run used it) with the least cost among the
disparities at least two pixels from ``d`` (its neighbours are left out: a cost curve is
never a single spike):

    confidence = (rival - cost) / rival,    at least -1

Near 1: the data single out ``d`` (a textured window, no repeated pattern). Near 0: a rival
a few pixels off fits as well (no texture, a repeated pattern); the DP or the feature pairs
chose between them. Below 0: the data prefer a rival and the path's smoothness and
occlusion costs overruled them. It is the run's own evidence, so it can rank the pixels
(keep the surest), not say which are wrong.

``sgm`` results take the same margin of ``sgm``'s own aggregated costs (the costs that chose
the disparity: :func:`dcstereo.methods.sgm.sgm_confidence`, in ``[0, 1]``), at the disparity the
winner-take-all chose.
"""

import numpy as np

from dcstereo.params import SGM_METHODS
from dcstereo.refine import _confidence as confidence_kernels
from dcstereo.result import FLAG_FILLED, DisparityResult, check_result_pair
from dcstereo.scanline import rows
from dcstereo.signal import padded_signal


def confidence(result: DisparityResult, left, right) -> np.ndarray:
    """Return the confidence of every pixel's disparity (see the module's text).

    Parameters
    ----------
    result : DisparityResult
        From :func:`dcstereo.match` (or :func:`~dcstereo.refine.subpixel.refine_subpixel`) on
        ``left`` and ``right``.
    left, right : ndarray
        The pair that was matched.

    Returns
    -------
    ndarray of float32, shape (H, W)
        In ``[-1, 1]``; NaN where there is no estimate, where it was filled, and where no
        disparity two pixels away has a cost (a range of fewer than three).
    """
    left, right = check_result_pair(result, left, right)
    d = result.disparity
    params = result.params  # MatchParams, or an OpenCV baseline's (no cost: SAD)
    if params.method in SGM_METHODS:
        from dcstereo.methods.sgm import sgm_confidence

        out = sgm_confidence(left, right, params)
        out[np.isnan(d) | ((result.flags & FLAG_FILLED) != 0)] = np.nan
        return out
    radius = params.window // 2
    wanted = np.isfinite(d) & ((result.flags & FLAG_FILLED) == 0)
    out = np.full(d.shape, np.nan, dtype=np.float32)
    confidence_kernels.confidence_rows(
        padded_signal(left, radius),
        padded_signal(right, radius),
        d,
        wanted,
        params.min_disparity,
        params.max_disparity - params.min_disparity + 1,
        radius,
        getattr(params, "cost", "sad") == "bt",
        rows.chunk_count(d.shape[0]),
        out,
    )
    return out
