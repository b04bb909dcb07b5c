"""OpenCV's StereoSGBM and StereoBM as baselines, returning a :class:`DisparityResult`.

OpenCV returns int16 fixed point (disparity times 16) with a sentinel,
``(min_disparity - 1) * 16``, for pixels without an estimate. :func:`match_opencv` turns
that into the project's convention: float32 pixels, ``x_right = x_left - d``, NaN where
there is no estimate (flagged :data:`~dcstereo.result.FLAG_OCCLUDED`), so the same
metrics and the same hole filling (:meth:`DisparityResult.filled`) apply to both.

OpenCV is an optional dependency: ``pip install "dcstereo[opencv]"``.

References
----------
H. Hirschmueller, "Stereo processing by semiglobal matching and mutual information",
IEEE TPAMI 30(2):328-341, 2008 (SGBM); K. Konolige, "Small vision systems: hardware and
implementation", ISRR 1997 (BM).
"""

import math
from dataclasses import dataclass

import numpy as np

from dcstereo._checks import is_integer
from dcstereo.result import FLAG_OCCLUDED, DisparityResult
from dcstereo.signal import check_pair, intensity

#: OpenCV methods, by the names the benchmark uses: the arguments of :func:`match_opencv`
#: each stands for (SGBM in its default mode and in ``MODE_HH``, the full eight-path one).
#: The tools run SGBM on the colour images when both are colour (``colour=True``).
OPENCV_METHODS = {
    "opencv-sgbm": {"method": "sgbm"},
    "opencv-hh": {"method": "sgbm", "mode": "hh"},
    "opencv-bm": {"method": "bm"},
}

_MODES = ("sgbm", "hh", "sgbm3way", "hh4")


def opencv_num_disparities(min_disparity: int, max_disparity: int) -> int:
    """Return how many disparities OpenCV searches for an inclusive range, from ``min_disparity``.

    The range's count rounded up to a multiple of 16: OpenCV's ``numDisparities`` must be one.
    """
    return 16 * math.ceil((max_disparity - min_disparity + 1) / 16)


@dataclass(frozen=True)
class OpenCVParams:
    """The settings of one OpenCV run (stands in for ``MatchParams`` in the result).

    Attributes
    ----------
    method : str
        ``"opencv-sgbm"`` or ``"opencv-bm"``.
    max_disparity, min_disparity : int
        The range asked for (inclusive).
    num_disparities : int
        What OpenCV searched: ``max_disparity - min_disparity + 1`` rounded up to a
        multiple of 16 (OpenCV requires it). Estimates above ``max_disparity`` are
        dropped (NaN), so both matchers answer within the same range.
    window : int
        ``blockSize`` (odd).
    p1, p2 : int
        SGBM smoothness penalties for a change of 1 and of more than 1 pixel (0 for BM).
    mode : str
        SGBM mode: ``"sgbm"`` (``MODE_SGBM``, 5 directions, one pass), ``"hh"``
        (``MODE_HH``, 8 directions), ``"sgbm3way"``, ``"hh4"``; ``""`` for BM.
    uniqueness_ratio, disp12_max_diff, speckle_window, speckle_range, pre_filter_cap : int
        Passed to OpenCV as they are.
    colour : bool
        Whether OpenCV was given the colour images (``cn = 3``) or gray ones.
    fill : bool
        Always False: fill with :meth:`DisparityResult.filled`.
    """

    method: str
    max_disparity: int
    min_disparity: int
    num_disparities: int
    window: int
    p1: int
    p2: int
    mode: str
    uniqueness_ratio: int
    disp12_max_diff: int
    speckle_window: int
    speckle_range: int
    pre_filter_cap: int
    colour: bool = False
    fill: bool = False


def _import_cv2():
    try:
        import cv2
    except ImportError as err:
        raise ImportError(
            'OpenCV is not installed; install the extra: pip install "dcstereo[opencv]"'
        ) from err
    return cv2


def _bgr8(image: np.ndarray) -> np.ndarray:
    """Return an RGB(A) image of any supported dtype as 8-bit BGR (OpenCV's channel order)."""
    rgb = np.asarray(image)[:, :, :3]
    if rgb.dtype == np.uint8:
        scaled = rgb
    elif rgb.dtype == np.uint16:
        scaled = np.rint(rgb / 257.0)
    else:
        scaled = np.rint(rgb * 255.0)
    return np.ascontiguousarray(np.clip(scaled, 0, 255).astype(np.uint8)[:, :, ::-1])


def match_opencv(
    left: np.ndarray,
    right: np.ndarray,
    *,
    max_disparity: int,
    min_disparity: int = 0,
    method: str = "sgbm",
    window: int = 5,
    p1: int | None = None,
    p2: int | None = None,
    mode: str = "sgbm",
    uniqueness_ratio: int | None = None,
    disp12_max_diff: int = 1,
    speckle_window: int = 100,
    speckle_range: int = 2,
    pre_filter_cap: int | None = None,
    colour: bool = False,
) -> DisparityResult:
    """Disparity of the left image with OpenCV's semi-global or block matcher.

    Both images are turned into 8-bit gray with the project's luma (``cn = 1`` below), or
    with ``colour`` (SGBM only, two colour images) into 8-bit BGR, OpenCV's channel order
    (``cn = 3``).

    Parameters
    ----------
    left, right : ndarray, shape (H, W) or (H, W, 3|4)
        Rectified pair, as for :func:`dcstereo.match`.
    max_disparity, min_disparity : int
        Inclusive search range in pixels. OpenCV searches ``numDisparities`` =
        ``max - min + 1`` rounded up to a multiple of 16; estimates beyond
        ``max_disparity`` become NaN. OpenCV needs ``min_disparity + numDisparities +
        window // 2 < W`` (and ``min_disparity > -W``).
    method : {"sgbm", "bm"}
        ``cv2.StereoSGBM`` or ``cv2.StereoBM``.
    window : int
        Odd ``blockSize``; BM needs 5 or more.
    p1, p2 : int, optional
        SGBM penalties; default the values OpenCV's documentation suggests,
        ``P1 = 8 * cn * window**2`` and ``P2 = 32 * cn * window**2`` with ``cn = 1``.
    mode : {"sgbm", "hh", "sgbm3way", "hh4"}
        SGBM mode; default ``MODE_SGBM`` (5 directions in one pass, OpenCV's default).
    uniqueness_ratio : int, optional
        Percent margin of the best cost over the second; default 10 (SGBM), 15 (BM).
    disp12_max_diff : int
        Left-right check tolerance in pixels (-1 disables it); default 1.
    speckle_window, speckle_range : int
        Speckle filter: regions under ``speckle_window`` pixels whose disparity varies by
        at most ``speckle_range`` are invalidated; default 100 and 2 (0 disables).
    pre_filter_cap : int, optional
        Clip of the x-derivative prefilter; default 63 (SGBM), 31 (BM).
    colour : bool
        SGBM on the colour images (both must have three or four channels; the defaults of
        ``p1`` and ``p2`` then take ``cn = 3``); default gray.

    Returns
    -------
    DisparityResult
        float32 disparity, NaN where OpenCV gives no estimate; ``params`` is an
        :class:`OpenCVParams`; ``path_cost`` is NaN (OpenCV does not report it).

    Raises
    ------
    ImportError
        When OpenCV is not installed (the message names the extra).
    ValueError
        For a bad image, range, window or mode.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> right = rng.integers(0, 256, (40, 80), dtype=np.uint8)
    >>> left = np.roll(right, 3, axis=1)
    >>> result = match_opencv(left, right, max_disparity=8)  # doctest: +SKIP
    >>> float(np.nanmedian(result.disparity[:, 20:]))  # doctest: +SKIP
    3.0
    """
    if method not in ("sgbm", "bm"):
        raise ValueError(f"method must be 'sgbm' or 'bm', got {method!r}")
    for name, value in (("max_disparity", max_disparity), ("min_disparity", min_disparity)):
        if not is_integer(value):
            raise TypeError(f"{name} must be an integer, got {value!r}")
    # OpenCV's own integer options: checked here, so that a wrong one is named (int()'s
    # message, or OpenCV's assertion, would not say which)
    lowest = {"p1": 0, "p2": 0, "uniqueness_ratio": 0, "disp12_max_diff": None,
              "speckle_window": 0, "speckle_range": 0, "pre_filter_cap": 1}  # fmt: skip
    given = {"p1": p1, "p2": p2, "uniqueness_ratio": uniqueness_ratio,
             "disp12_max_diff": disp12_max_diff, "speckle_window": speckle_window,
             "speckle_range": speckle_range, "pre_filter_cap": pre_filter_cap}  # fmt: skip
    for name, value in given.items():
        if value is None:
            continue
        if not is_integer(value):
            raise TypeError(f"{name} must be an integer, got {value!r}")
        if lowest[name] is not None and value < lowest[name]:
            raise ValueError(f"{name} must be at least {lowest[name]}, got {value}")
    if pre_filter_cap is not None and pre_filter_cap > 63:
        raise ValueError(f"pre_filter_cap must be 1 to 63 (OpenCV's bound), got {pre_filter_cap}")
    if max_disparity < min_disparity:
        raise ValueError(
            f"max_disparity ({max_disparity}) must not be smaller than min_disparity "
            f"({min_disparity})"
        )
    if (
        isinstance(window, bool)
        or not isinstance(window, int | np.integer)
        or window < 1
        or window % 2 == 0
    ):
        raise ValueError(f"window must be a positive odd integer, got {window!r}")
    window = int(window)
    if method == "bm" and window < 5:
        raise ValueError(f"OpenCV's block matcher needs window >= 5, got {window}")
    if method == "sgbm" and mode not in _MODES:
        raise ValueError(f"mode must be one of {', '.join(_MODES)}, got {mode!r}")
    left, right = check_pair(left, right)
    width = left.shape[1]
    num = opencv_num_disparities(min_disparity, max_disparity)
    # OpenCV's own bound (SGBM raises, BM answers garbage past it): the rounded-up range
    # and half the window must leave a column of the image to match.
    if min_disparity <= -width:
        raise ValueError(
            f"min_disparity={min_disparity} does not fit an image {width} pixels wide "
            f"(it must be at least {-(width - 1)})"
        )
    if min_disparity + num + window // 2 >= width:
        raise ValueError(
            f"disparities {min_disparity}..{max_disparity} with window {window} do not fit "
            f"OpenCV {method} on an image {width} pixels wide: it needs min_disparity + "
            f"numDisparities ({num}, the range rounded up to 16) + window // 2 < {width}"
        )
    cv2 = _import_cv2()

    if colour:
        if method != "sgbm":
            raise ValueError("colour=True is for OpenCV's SGBM; its block matcher takes gray")
        if left.ndim != 3 or right.ndim != 3:
            raise ValueError("colour=True needs two colour images (H, W, 3|4)")
        gray_left, gray_right = _bgr8(left), _bgr8(right)
    else:
        gray_left = np.clip(np.rint(intensity(left)), 0, 255).astype(np.uint8)
        gray_right = np.clip(np.rint(intensity(right)), 0, 255).astype(np.uint8)
    cn = 3 if colour else 1
    if method == "sgbm":
        p1 = 8 * cn * window * window if p1 is None else int(p1)
        p2 = 32 * cn * window * window if p2 is None else int(p2)
        uniqueness_ratio = 10 if uniqueness_ratio is None else int(uniqueness_ratio)
        pre_filter_cap = 63 if pre_filter_cap is None else int(pre_filter_cap)
        modes = {
            "sgbm": cv2.STEREO_SGBM_MODE_SGBM,
            "hh": cv2.STEREO_SGBM_MODE_HH,
            "sgbm3way": cv2.STEREO_SGBM_MODE_SGBM_3WAY,
            "hh4": cv2.STEREO_SGBM_MODE_HH4,
        }
        matcher = cv2.StereoSGBM_create(
            minDisparity=int(min_disparity),
            numDisparities=num,
            blockSize=window,
            P1=p1,
            P2=p2,
            disp12MaxDiff=int(disp12_max_diff),
            preFilterCap=pre_filter_cap,
            uniquenessRatio=uniqueness_ratio,
            speckleWindowSize=int(speckle_window),
            speckleRange=int(speckle_range),
            mode=modes[mode],
        )
    else:
        p1 = p2 = 0
        mode = ""
        uniqueness_ratio = 15 if uniqueness_ratio is None else int(uniqueness_ratio)
        pre_filter_cap = 31 if pre_filter_cap is None else int(pre_filter_cap)
        matcher = cv2.StereoBM_create(numDisparities=num, blockSize=window)
        matcher.setMinDisparity(int(min_disparity))
        matcher.setUniquenessRatio(uniqueness_ratio)
        matcher.setPreFilterCap(pre_filter_cap)
        matcher.setDisp12MaxDiff(int(disp12_max_diff))
        matcher.setSpeckleWindowSize(int(speckle_window))
        matcher.setSpeckleRange(int(speckle_range))
    try:
        fixed = matcher.compute(gray_left, gray_right)
    except cv2.error as err:
        message = str(err).strip().splitlines()[-1] if str(err).strip() else "cv2.error"
        raise ValueError(f"OpenCV {method} failed: {message}") from None
    disparity = fixed.astype(np.float32) / np.float32(16.0)
    # Below min_disparity: the sentinel (min - 1) * 16 or anything OpenCV marks invalid.
    invalid = (fixed < min_disparity * 16) | (disparity > max_disparity)
    disparity[invalid] = np.nan
    flags = np.where(invalid, FLAG_OCCLUDED, 0).astype(np.uint8)
    params = OpenCVParams(
        method=f"opencv-{method}",
        max_disparity=int(max_disparity),
        min_disparity=int(min_disparity),
        num_disparities=num,
        window=window,
        p1=p1,
        p2=p2,
        mode=mode,
        uniqueness_ratio=uniqueness_ratio,
        disp12_max_diff=int(disp12_max_diff),
        speckle_window=int(speckle_window),
        speckle_range=int(speckle_range),
        pre_filter_cap=pre_filter_cap,
        colour=bool(colour),
    )
    path_cost = np.full(disparity.shape[0], np.nan)
    return DisparityResult(disparity, flags, params, path_cost)
