"""``StereoDC``: :func:`dcstereo.match` behind OpenCV's ``StereoSGBM`` interface.

For code written against OpenCV: ``StereoDC.create`` takes the keywords of
``cv2.StereoSGBM_create`` (and its positional order), ``compute(left, right)`` returns
OpenCV's format (``int16`` disparity times 16, ``(minDisparity - 1) * 16`` where there is
no estimate, the input's height and width), and the getters and setters of
``cv2.StereoSGBM`` are there. So a program changes one line::

    matcher = cv2.StereoSGBM_create(minDisparity=0, numDisparities=64, blockSize=5)
    matcher = dcstereo.StereoDC.create(minDisparity=0, numDisparities=64, blockSize=5)

and ``cv2.reprojectImageTo3D(disparity.astype(np.float32) / 16, Q)`` works on the result.
No OpenCV is needed: this module does not import it.

Each OpenCV option maps onto a keyword of :func:`dcstereo.match` through one table,
:data:`OPENCV_OPTIONS`. An option whose keyword the method in use does not read (today
``P1`` and ``P2``, whose units are OpenCV's, ``preFilterCap``, ``uniquenessRatio`` and the
speckle filter; with the paper's ``dc`` also ``disp12MaxDiff`` and ``mode``, which map onto
``sgm``'s left-right check and paths) is accepted, kept and reported by its getter, but
changes nothing; ``StereoDC.unusedOptions()`` lists those
set to another value than OpenCV's default, and ``strict=True`` refuses them instead.
"""

import inspect
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from dcstereo._checks import is_integer
from dcstereo.api import match
from dcstereo.params import METHOD_OPTIONS, MatchParams
from dcstereo.result import DisparityResult
from dcstereo.signal import check_image

#: OpenCV's fixed point: stored value per pixel of disparity.
DISPARITY_SCALE = 16

#: The largest disparity (in pixels) whose fixed-point value fits OpenCV's int16.
MAX_FIXED_DISPARITY = (np.iinfo(np.int16).max + 1) // DISPARITY_SCALE - 1

#: ``cv2.StereoSGBM``'s modes (the same integers as ``cv2.STEREO_SGBM_MODE_*``).
MODE_SGBM, MODE_HH, MODE_SGBM_3WAY, MODE_HH4 = 0, 1, 2, 3

#: The colour orders ``compute`` understands for (H, W, 3|4) images.
COLOR_ORDERS = ("BGR", "RGB")


@dataclass(frozen=True)
class OpenCVOption:
    """One row of :data:`OPENCV_OPTIONS`: an OpenCV setting and what it becomes here.

    Attributes
    ----------
    name : str
        OpenCV's keyword (and the stem of its getter and setter: ``getP1``, ``setP1``).
    default : int or None
        ``StereoDC.create``'s default: OpenCV's for every setting but
        ``numDisparities`` (64) and ``blockSize`` (None: the method's window). For the
        settings beyond the range and the window, that value leaves the method's own
        default (OpenCV's 0 often means "choose for me").
    keyword : str or None
        The keyword of :func:`dcstereo.match` it sets, or None: it sets nothing. It takes
        effect only with a method that reads that keyword
        (:data:`dcstereo.params.METHOD_OPTIONS`; the keywords outside that table are read
        by every method).
    convert : callable or None
        Turns OpenCV's value into the keyword's (None: the value as it is).
    meaning : str
        What it does here, or why it does nothing.
    """

    name: str
    default: int | None
    keyword: str | None = None
    convert: Callable[[int], object] | None = None
    meaning: str = ""


#: OpenCV's StereoSGBM settings, in ``cv2.StereoSGBM_create``'s positional order, and
#: the keyword of :func:`dcstereo.match` each becomes. A method that gains an equivalent
#: (smoothness penalties, a left-right check, a uniqueness test, path modes) is mapped
#: here, one row each: set ``keyword`` (and ``convert``).
OPENCV_OPTIONS = (
    OpenCVOption("minDisparity", 0, "min_disparity", None, "smallest disparity searched"),
    OpenCVOption(
        "numDisparities",
        64,
        "max_disparity",
        None,
        "number of disparities searched, minDisparity .. minDisparity + numDisparities - 1; "
        "any positive count (OpenCV's multiples of 16 work as they are)",
    ),
    OpenCVOption("blockSize", None, "window", None, "odd side of the matching window"),
    OpenCVOption(
        "P1",
        0,
        None,
        None,
        "smoothness penalty of a change of 1 pixel; sgm's are in its own cost units "
        "(give p1= instead: OpenCV's 8 * channels * blockSize**2 would mean another thing)",
    ),
    OpenCVOption("P2", 0, None, None, "smoothness penalty of a larger change (sgm: p2=)"),
    OpenCVOption(
        "disp12MaxDiff",
        0,
        "lr_tolerance",
        lambda v: None if v < 0 else int(v),
        "left-right check tolerance in pixels (sgm's lr_tolerance; negative: no check)",
    ),
    OpenCVOption("preFilterCap", 0, None, None, "clip of the x-derivative prefilter"),
    OpenCVOption("uniquenessRatio", 0, None, None, "margin of the best cost, percent"),
    OpenCVOption("speckleWindowSize", 0, None, None, "speckle filter: region size"),
    OpenCVOption("speckleRange", 0, None, None, "speckle filter: disparity variation"),
    OpenCVOption(
        "mode",
        MODE_SGBM,
        "paths",
        lambda v: 4 if v == MODE_HH4 else 8,
        "aggregation paths: MODE_HH4 gives sgm's 4 paths, the others its 8",
    ),
)

# the keywords StereoDC fills from OpenCV's settings (given as options they would clash)
_RANGE_KEYWORDS = {
    "min_disparity": "minDisparity",
    "max_disparity": "numDisparities",
    "window": "blockSize",
}


def default_method() -> str:
    """Return the method :func:`dcstereo.match` runs when it is given none."""
    return inspect.signature(match).parameters["method"].default


def _check_setting(name: str, value) -> int:
    """Validate the OpenCV setting ``name``; return it as a Python int."""
    if name == "blockSize" and value is None:
        return None  # the method's default window
    if not is_integer(value):
        raise TypeError(f"{name} must be an integer, got {value!r}")
    value = int(value)
    lowest = MAX_FIXED_DISPARITY
    if name == "minDisparity" and not -lowest <= value <= lowest:
        raise ValueError(
            f"minDisparity must be from {-lowest} to {lowest} (OpenCV's int16 fixed point), "
            f"got {value}"
        )
    if name == "numDisparities" and value < 1:
        raise ValueError(f"numDisparities must be at least 1, got {value}")
    if name == "blockSize" and (value < 1 or value % 2 == 0):
        raise ValueError(f"blockSize must be a positive odd integer, got {value}")
    if name == "mode" and value not in (MODE_SGBM, MODE_HH, MODE_SGBM_3WAY, MODE_HH4):
        raise ValueError(
            f"mode must be one of MODE_SGBM (0), MODE_HH (1), MODE_SGBM_3WAY (2), "
            f"MODE_HH4 (3), got {value}"
        )
    if name in ("P1", "P2", "preFilterCap", "uniquenessRatio", "speckleWindowSize",
                "speckleRange") and value < 0:  # fmt: skip
        raise ValueError(f"{name} must be 0 or more, got {value}")
    return value


def to_fixed_point(disparity: np.ndarray, min_disparity: int, max_disparity: int) -> np.ndarray:
    """Return a float disparity map in OpenCV's format: ``int16``, disparity times 16.

    Parameters
    ----------
    disparity : ndarray of float, shape (H, W)
        Disparity in pixels, NaN where there is no estimate (a
        :attr:`DisparityResult.disparity`).
    min_disparity, max_disparity : int
        The range searched; estimates are rounded to 1/16 pixel and kept within it.

    Returns
    -------
    ndarray of int16, shape (H, W)
        ``round(16 * d)``; ``(min_disparity - 1) * 16`` where there is no estimate.

    Examples
    --------
    >>> to_fixed_point(np.array([[2.0, 2.5, np.nan]]), 0, 8)
    array([[ 32,  40, -16]], dtype=int16)
    """
    d = np.asarray(disparity, dtype=np.float64)
    finite = np.isfinite(d)
    low, high = DISPARITY_SCALE * min_disparity, DISPARITY_SCALE * max_disparity
    fixed = np.clip(np.rint(np.where(finite, d, 0.0) * DISPARITY_SCALE), low, high)
    out = np.where(finite, fixed, DISPARITY_SCALE * (min_disparity - 1))
    return out.astype(np.int16)


class StereoDC:
    """Dense stereo matching with :func:`dcstereo.match`, shaped like ``cv2.StereoSGBM``.

    Make one with :meth:`create` (the constructor takes the same arguments);
    :meth:`compute` returns OpenCV's fixed-point disparity, :meth:`match` dcstereo's full
    :class:`~dcstereo.DisparityResult` (NaN where there is no estimate, and why). The
    method is :func:`dcstereo.match`'s default unless ``method=`` names another, with
    :func:`dcstereo.match`'s options as they are unless given.

    Parameters
    ----------
    minDisparity : int, default 0
        Smallest disparity searched (may be negative).
    numDisparities : int, default 64
        How many disparities are searched: ``minDisparity .. minDisparity +
        numDisparities - 1``. Any positive count; OpenCV's multiples of 16 as they are.
    blockSize : int, optional
        Odd side of the matching window (:func:`dcstereo.match`'s ``window``);
        default the method's.
    P1, P2, disp12MaxDiff, preFilterCap, uniquenessRatio, speckleWindowSize, speckleRange : int
        OpenCV's other settings (by name, or by position in OpenCV's order): each mapped
        through :data:`OPENCV_OPTIONS` where the method reads an equivalent, otherwise
        kept (the getters report it) without effect; OpenCV's default value, 0, leaves
        the method's own default.
    mode : int
        ``StereoDC.MODE_SGBM`` (0, the default), ``MODE_HH``, ``MODE_SGBM_3WAY`` or
        ``MODE_HH4``, the integers of ``cv2.STEREO_SGBM_MODE_*``; as the settings above.
    method : str, optional
        A method of :data:`dcstereo.METHODS`; default :func:`dcstereo.match`'s.
    color_order : {"BGR", "RGB"}
        The channel order of colour images given to :meth:`compute`: ``"BGR"``,
        OpenCV's (``cv2.imread``), by default; ``"RGB"`` for images read with
        :func:`dcstereo.io.read_image`, Pillow or imageio.
    strict : bool
        Refuse (``ValueError``) an OpenCV setting the method does not read when it
        has another value than OpenCV's default, instead of keeping it without effect.
    **options
        Other keywords of :func:`dcstereo.match` (``fill``, ``occlusion_cost``,
        ``subpixel``, ...), not the range and the window, which come from
        ``minDisparity``, ``numDisparities`` and ``blockSize``.

    Raises
    ------
    TypeError, ValueError
        For a setting or an option :func:`dcstereo.match` would refuse (named).

    Examples
    --------
    >>> import numpy as np, dcstereo
    >>> rng = np.random.default_rng(0)
    >>> right = rng.integers(0, 256, (20, 48), dtype=np.uint8)
    >>> left = np.roll(right, 3, axis=1)  # every left pixel matches x - 3
    >>> matcher = dcstereo.StereoDC.create(minDisparity=0, numDisparities=8, blockSize=5)
    >>> disparity = matcher.compute(left, right)  # int16, d * 16
    >>> disparity.dtype, int(np.median(disparity[:, 8:]))
    (dtype('int16'), 48)
    """

    MODE_SGBM = MODE_SGBM
    MODE_HH = MODE_HH
    MODE_SGBM_3WAY = MODE_SGBM_3WAY
    MODE_HH4 = MODE_HH4

    def __init__(
        self,
        minDisparity: int = 0,
        numDisparities: int = 64,
        blockSize: int | None = None,
        P1: int = 0,
        P2: int = 0,
        disp12MaxDiff: int = 0,
        preFilterCap: int = 0,
        uniquenessRatio: int = 0,
        speckleWindowSize: int = 0,
        speckleRange: int = 0,
        mode: int = MODE_SGBM,
        *,
        method: str | None = None,
        color_order: str = "BGR",
        strict: bool = False,
        **options,
    ):
        """Make a matcher (see the class's parameters)."""
        given = locals()
        settings = {row.name: given[row.name] for row in OPENCV_OPTIONS}
        self._settings: dict = {}
        self._method: str | None = None
        self._options: dict = {}
        self._color_order = "BGR"
        self._strict = False
        self._configure(settings, method, color_order, strict, options)

    @classmethod
    def create(cls, *args, **kwargs) -> "StereoDC":
        """Make a matcher: ``StereoDC.create(...)`` is ``StereoDC(...)``, as in OpenCV.

        Parameters
        ----------
        *args, **kwargs
            The arguments of :class:`StereoDC`: ``cv2.StereoSGBM_create``'s (by name, or
            by position in OpenCV's order) and ours.

        Returns
        -------
        StereoDC

        Examples
        --------
        >>> matcher = StereoDC.create(0, 64, 5, fill=True)  # positional, as OpenCV's
        >>> matcher.getNumDisparities(), matcher.getMatchOptions()
        (64, {'fill': True})
        """
        return cls(*args, **kwargs)

    def _configure(self, settings, method, color_order, strict, options):
        """Check a whole configuration, then take it (a refused change changes nothing)."""
        checked = {name: _check_setting(name, value) for name, value in settings.items()}
        if color_order not in COLOR_ORDERS:
            raise ValueError(f"color_order must be 'BGR' or 'RGB', got {color_order!r}")
        if not isinstance(strict, bool):
            raise TypeError(f"strict must be True or False, got {strict!r}")
        if method is not None and not isinstance(method, str):
            raise TypeError(f"method must be a method name or None, got {method!r}")
        for name in options:
            if name in _RANGE_KEYWORDS:
                raise ValueError(
                    f"{name} is set by {_RANGE_KEYWORDS[name]} in StereoDC, not as an option"
                )
        run = method or default_method()
        # MatchParams refuses what match would, naming the option
        MatchParams(**_keywords(checked, run, strict), method=run, **options)
        self._settings, self._method, self._options = checked, method, dict(options)
        self._color_order, self._strict = color_order, strict

    def _change(self, **changes):
        current = {
            "settings": self._settings,
            "method": self._method,
            "color_order": self._color_order,
            "strict": self._strict,
            "options": self._options,
        }
        current.update(changes)
        self._configure(**current)

    def _set(self, name, value):
        self._change(settings={**self._settings, name: value})

    def match_keywords(self) -> dict:
        """Return the keyword arguments :meth:`compute` gives :func:`dcstereo.match`.

        The mapped OpenCV settings, the method when one was chosen, and the options.

        Examples
        --------
        >>> StereoDC.create(numDisparities=16, P1=8).match_keywords()
        {'min_disparity': 0, 'max_disparity': 15}
        """
        keywords = _keywords(self._settings, self.getMethod(), self._strict)
        if self._method is not None:
            keywords["method"] = self._method
        return {**keywords, **self._options}

    def params(self) -> MatchParams:
        """Return the :class:`~dcstereo.MatchParams` :meth:`compute` runs with."""
        return MatchParams(**{**self.match_keywords(), "method": self.getMethod()})

    def unusedOptions(self) -> list[str]:
        """Return the OpenCV settings given a non-default value that change nothing.

        Those whose keyword the method in use does not read (see :data:`OPENCV_OPTIONS`).

        Examples
        --------
        >>> StereoDC.create(numDisparities=16, P1=8, P2=32).unusedOptions()
        ['P1', 'P2']
        """
        method = self.getMethod()
        return [
            row.name
            for row in OPENCV_OPTIONS
            if self._settings[row.name] != row.default and not _reads(row, method)
        ]

    # --- matching -----------------------------------------------------------------------

    def match(self, left: np.ndarray, right: np.ndarray) -> DisparityResult:
        """Match a pair; return dcstereo's result (float disparity, NaN = none, flags).

        ``left`` and ``right`` as for :meth:`compute` (colour in ``color_order``).
        """
        return match(self._rgb(left, "left"), self._rgb(right, "right"), **self.match_keywords())

    def compute(
        self, left: np.ndarray, right: np.ndarray, disparity: np.ndarray | None = None
    ) -> np.ndarray:
        """Return the disparity of ``left`` in OpenCV's format.

        Parameters
        ----------
        left, right : ndarray, shape (H, W) or (H, W, 3|4)
            The rectified pair: gray, or colour in the ``color_order`` of :meth:`create`
            (BGR by default, as ``cv2.imread`` gives it); ``uint8`` as OpenCV takes, and
            also ``uint16`` or float in ``[0, 1]`` (see :func:`dcstereo.match`).
        disparity : ndarray of int16, shape (H, W), optional
            Written in place and returned, as OpenCV's output argument.

        Returns
        -------
        ndarray of int16, shape (H, W)
            ``round(16 * d)`` with ``x_right = x_left - d``; ``(minDisparity - 1) * 16``
            where there is no estimate (occluded, beyond the border).

        Raises
        ------
        TypeError, ValueError
            For images :func:`dcstereo.match` refuses, or a ``disparity`` that is not a
            writable int16 array of the images' height and width.
        """
        if disparity is not None and not (
            isinstance(disparity, np.ndarray)
            and disparity.dtype == np.int16
            and disparity.flags.writeable
        ):
            raise TypeError(f"disparity must be a writable int16 array, got {_describe(disparity)}")
        result = self.match(left, right)
        low = self._settings["minDisparity"]
        fixed = to_fixed_point(result.disparity, low, low + self._settings["numDisparities"] - 1)
        if disparity is None:
            return fixed
        if disparity.shape != fixed.shape:
            raise ValueError(
                f"disparity has shape {disparity.shape}, the images {fixed.shape}: it must "
                "have the images' height and width"
            )
        disparity[...] = fixed
        return disparity

    def _rgb(self, image, name):
        """Check an input image; colour in this matcher's order becomes RGB."""
        array = check_image(image, name)
        if array.ndim == 3 and self._color_order == "BGR":
            array = array[:, :, 2::-1]  # BGR(A) -> RGB; the luma ignores alpha
        return array

    # --- OpenCV's getters and setters ---------------------------------------------------

    def getMinDisparity(self) -> int:
        """Return ``minDisparity``, the smallest disparity searched."""
        return self._settings["minDisparity"]

    def setMinDisparity(self, value: int) -> None:
        """Set ``minDisparity``."""
        self._set("minDisparity", value)

    def getNumDisparities(self) -> int:
        """Return ``numDisparities``, how many disparities are searched."""
        return self._settings["numDisparities"]

    def setNumDisparities(self, value: int) -> None:
        """Set ``numDisparities`` (any positive count)."""
        self._set("numDisparities", value)

    def getBlockSize(self) -> int:
        """Return ``blockSize``, the window side (the method's when none was set)."""
        return self.params().window

    def setBlockSize(self, value: int | None) -> None:
        """Set ``blockSize`` (odd; None: the method's default window)."""
        self._set("blockSize", value)

    def getP1(self) -> int:
        """Return ``P1`` as set (see :data:`OPENCV_OPTIONS` for its effect)."""
        return self._settings["P1"]

    def setP1(self, value: int) -> None:
        """Set ``P1``."""
        self._set("P1", value)

    def getP2(self) -> int:
        """Return ``P2`` as set (see :data:`OPENCV_OPTIONS` for its effect)."""
        return self._settings["P2"]

    def setP2(self, value: int) -> None:
        """Set ``P2``."""
        self._set("P2", value)

    def getDisp12MaxDiff(self) -> int:
        """Return ``disp12MaxDiff`` as set (see :data:`OPENCV_OPTIONS` for its effect)."""
        return self._settings["disp12MaxDiff"]

    def setDisp12MaxDiff(self, value: int) -> None:
        """Set ``disp12MaxDiff``."""
        self._set("disp12MaxDiff", value)

    def getPreFilterCap(self) -> int:
        """Return ``preFilterCap`` as set (see :data:`OPENCV_OPTIONS` for its effect)."""
        return self._settings["preFilterCap"]

    def setPreFilterCap(self, value: int) -> None:
        """Set ``preFilterCap``."""
        self._set("preFilterCap", value)

    def getUniquenessRatio(self) -> int:
        """Return ``uniquenessRatio`` as set (see :data:`OPENCV_OPTIONS` for its effect)."""
        return self._settings["uniquenessRatio"]

    def setUniquenessRatio(self, value: int) -> None:
        """Set ``uniquenessRatio``."""
        self._set("uniquenessRatio", value)

    def getSpeckleWindowSize(self) -> int:
        """Return ``speckleWindowSize`` as set (see :data:`OPENCV_OPTIONS` for its effect)."""
        return self._settings["speckleWindowSize"]

    def setSpeckleWindowSize(self, value: int) -> None:
        """Set ``speckleWindowSize``."""
        self._set("speckleWindowSize", value)

    def getSpeckleRange(self) -> int:
        """Return ``speckleRange`` as set (see :data:`OPENCV_OPTIONS` for its effect)."""
        return self._settings["speckleRange"]

    def setSpeckleRange(self, value: int) -> None:
        """Set ``speckleRange``."""
        self._set("speckleRange", value)

    def getMode(self) -> int:
        """Return ``mode`` as set (see :data:`OPENCV_OPTIONS` for its effect)."""
        return self._settings["mode"]

    def setMode(self, value: int) -> None:
        """Set ``mode`` (``StereoDC.MODE_SGBM``, ``MODE_HH``, ...)."""
        self._set("mode", value)

    # --- ours, and cv2.Algorithm's ------------------------------------------------------

    def getMethod(self) -> str:
        """Return the method :meth:`compute` runs (:func:`dcstereo.match`'s default unless set)."""
        return self._method or default_method()

    def setMethod(self, method: str | None) -> None:
        """Choose the method (None: :func:`dcstereo.match`'s default)."""
        self._change(method=method)

    def getMatchOptions(self) -> dict:
        """Return the keywords of :func:`dcstereo.match` given besides OpenCV's settings."""
        return dict(self._options)

    def setMatchOptions(self, **options) -> None:
        """Set keywords of :func:`dcstereo.match` (added to those given before)."""
        self._change(options={**self._options, **options})

    def getColorOrder(self) -> str:
        """Return the channel order assumed for colour images (``"BGR"`` or ``"RGB"``)."""
        return self._color_order

    def setColorOrder(self, order: str) -> None:
        """Set the channel order of colour images: ``"BGR"`` (OpenCV's) or ``"RGB"``."""
        self._change(color_order=order)

    def empty(self) -> bool:
        """Return False, as OpenCV's matchers do (``cv2.Algorithm.empty``)."""
        return False

    def clear(self) -> None:
        """Do nothing (``cv2.Algorithm.clear``; a StereoDC keeps no state between calls)."""

    def getDefaultName(self) -> str:
        """Return the algorithm's name, ``"dcstereo.StereoDC"``."""
        return "dcstereo.StereoDC"

    def __repr__(self) -> str:
        """Show the range, the settings given, the options and the method."""
        shown = [
            f"{row.name}={self._settings[row.name]}"
            for row in OPENCV_OPTIONS
            if row.name in ("minDisparity", "numDisparities")
            or self._settings[row.name] != row.default
        ]
        shown += [f"{name}={value!r}" for name, value in self._options.items()]
        return f"StereoDC({', '.join(shown)}, method={self.getMethod()!r})"


def _reads(row: OpenCVOption, method: str) -> bool:
    """Whether the keyword of ``row`` exists and ``method`` reads it."""
    if row.keyword is None:
        return False
    if row.keyword in _RANGE_KEYWORDS:
        return True
    if row.keyword not in {f.name for f in MatchParams.__dataclass_fields__.values()}:
        return False
    readers = METHOD_OPTIONS.get(row.keyword)
    return readers is None or method in readers


def _keywords(settings: dict, method: str, strict: bool) -> dict:
    """Return the keywords of :func:`dcstereo.match` that OpenCV's ``settings`` give."""
    low = settings["minDisparity"]
    high = low + settings["numDisparities"] - 1
    if high > MAX_FIXED_DISPARITY:
        raise ValueError(
            f"minDisparity + numDisparities - 1 = {high} does not fit OpenCV's int16 fixed "
            f"point (at most {MAX_FIXED_DISPARITY})"
        )
    keywords = {"min_disparity": low, "max_disparity": high}
    if settings["blockSize"] is not None:
        keywords["window"] = settings["blockSize"]
    for row in OPENCV_OPTIONS:
        if row.keyword in _RANGE_KEYWORDS:
            continue
        value = settings[row.name]
        if value == row.default:
            continue  # OpenCV's default: the method's own
        if not _reads(row, method):
            if strict:
                raise ValueError(
                    f"{row.name} has no effect with method {method!r} ({row.meaning}); "
                    f"leave it at {row.default} or use strict=False"
                )
            continue
        keywords[row.keyword] = value if row.convert is None else row.convert(value)
    return keywords


def _describe(value) -> str:
    if isinstance(value, np.ndarray):
        return f"{value.dtype} array of shape {value.shape}"
    return type(value).__name__
