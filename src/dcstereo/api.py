"""``match``: validate the pair, pick the method from a plain dict, return the result."""

import numpy as np

from dcstereo.methods import REGISTRY
from dcstereo.params import DEFAULT_METHOD, MatchParams
from dcstereo.result import DisparityResult
from dcstereo.signal import check_pair


def match(
    left: np.ndarray,
    right: np.ndarray,
    *,
    max_disparity: int,
    min_disparity: int = 0,
    method: str = DEFAULT_METHOD,
    **options,
) -> DisparityResult:
    """Estimate the disparity of the left image of a rectified stereo pair.

    A left pixel ``(x, y)`` matches the right pixel ``(x - d, y)``; disparities
    ``min_disparity..max_disparity`` (inclusive) are searched.

    Parameters
    ----------
    left, right : ndarray, shape (H, W) or (H, W, 3|4)
        Rectified pair of one height and width, ``uint8``, ``uint16`` or float in
        ``[0, 1]``; colour becomes luma (see :mod:`dcstereo.signal`), each image on its
        own, so a gray and a colour image may be paired.
    max_disparity, min_disparity : int
        Inclusive search range in pixels.
    method : str
        ``"sgm"`` (default, :mod:`dcstereo.methods.sgm`): census and colour costs,
        semi-global aggregation along 8 paths, a left-right check, an edge-aware fill, a
        median and a sub-pixel fit. ``"sgm-accurate"``: ``sgm`` with the five stages that
        won on the development scenes (the right view's colours and rows aligned to the
        left's, superpixel planes, the weighted median with local planes, the depth edges
        decided again): the most accurate, about four times ``sgm``'s time. The paper's
        methods, kept exact: ``"dc"``, the
        divide-and-conquer matcher of Tsai and Katsaggelos (reliable feature pairs, by SER
        and VS and the ordering constraint, pin the path of each scanline and the
        five-step DP fills between them); ``"dc-linear"``: the same pairs, interpolated
        linearly; ``"dsi5"``: the five-step DP of eq. 5; ``"dsi3"``: the three-step DP
        (Intille and Bobick); ``"dsi3-gcp"``: the three-step DP through ground control
        points; ``"redert"``: the DP with occlusion and orientation of Redert, Tsai,
        Hendriks and Katsaggelos (reconstructed, see :mod:`dcstereo.methods.redert`);
        ``"block"``: winner-take-all block matching (Hannah). Each is a list of stages,
        :data:`dcstereo.methods.REGISTRY`.
    **options
        The method's parameters (:class:`~dcstereo.params.MatchParams`; an option the
        method does not read is refused). The defaults that depend on the method
        (:data:`~dcstereo.params.METHOD_DEFAULTS`): for ``sgm`` ``window`` 3 (the box
        over which the costs are averaged), ``cost`` ``"census-ad"``, ``fill`` True,
        ``median`` 5, ``subpixel`` ``"equiangular"``; for the paper's methods ``window``
        5 (the SAD window of eq. 4), ``cost`` ``"sad"`` (or ``"bt"``), ``fill`` False,
        ``median`` 0, ``subpixel`` None; ``sgm-accurate`` as ``sgm`` but ``median``
        ``"weighted-planes"``. ``sgm``'s own (``sgm-accurate`` reads them too): ``census_window``
        (5, 5), ``ad_truncation`` 20, ``p1`` 60, ``p2`` 400, ``p2_gradient`` 6.0,
        ``paths`` 8, ``lr_tolerance`` 1. The paper's: ``occlusion_cost`` 10.0 gray levels of
        mean absolute difference per pixel, and ``dc``'s feature tests (``ser_min``,
        ``vs_max``, ``uniqueness``, ...).

    Returns
    -------
    DisparityResult

    Examples
    --------
    >>> import numpy as np, dcstereo
    >>> rng = np.random.default_rng(0)
    >>> right = rng.integers(0, 256, (20, 40), dtype=np.uint8)
    >>> left = np.roll(right, 3, axis=1)  # every left pixel matches x - 3
    >>> result = dcstereo.match(left, right, max_disparity=6)
    >>> round(float(np.nanmedian(result.disparity)), 2)  # sgm's sub-pixel estimates
    3.0
    """
    params = MatchParams(
        max_disparity=max_disparity, min_disparity=min_disparity, method=method, **options
    )
    left, right = check_pair(left, right)
    height, width = left.shape[:2]
    params.check_image_size(height, width)
    try:
        result = REGISTRY[params.method].run(left, right, params)
    except (SystemError, MemoryError) as err:
        # numpy's MemoryError, or numba's SystemError for an allocation that failed inside
        # a parallel kernel: one line that says what did not fit
        if not isinstance(err, MemoryError) and not isinstance(err.__cause__, MemoryError):
            raise
        raise MemoryError(
            f"out of memory matching {height} x {width} images over "
            f"{params.num_disparities} disparities with method {params.method!r}"
        ) from err
    return result
