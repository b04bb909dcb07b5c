"""Turn disparity maps into images: the paper's gray display, colour maps, error maps.

And show them where users look at their data: :func:`log_rerun` logs a result to the
`Rerun <https://rerun.io>`_ viewer (the optional extra ``dcstereo[rerun]``), into a
recording of its own made by :func:`rerun_recording`.
"""

import contextlib
import logging
import os
import shutil
import sys
from collections.abc import Iterator

import numpy as np

from dcstereo._checks import disparity_array, is_integer, is_number
from dcstereo._extras import require

#: Brightest gray level of a valid pixel in :func:`paper_display`; occluded pixels get 255.
PAPER_MAX_GRAY = 223
#: Colours of :func:`error_map`.
ERROR_GOOD = (200, 200, 200)
ERROR_BAD = (255, 0, 0)
ERROR_MISSING = (0, 0, 255)
ERROR_UNSCORED = (0, 0, 0)

#: The styles of :func:`preview`.
PREVIEW_STYLES = ("paper", "color")


def check_preview_style(style: str, name: str = "preview style") -> None:
    """Raise ``ValueError`` unless ``style`` is one of :data:`PREVIEW_STYLES`.

    ``name`` is the argument's name in the message.
    """
    if style not in PREVIEW_STYLES:
        raise ValueError(f"unknown {name} {style!r}; use one of {', '.join(PREVIEW_STYLES)}")


def paper_display(disparity: np.ndarray, occluded: np.ndarray | None = None) -> np.ndarray:
    """Gray display of a disparity map as in the figures of Tsai and Katsaggelos.

    The finite disparities are histogram-equalized into gray levels ``0..223`` (larger
    disparity = brighter) and occluded pixels are drawn white (255), so they stand out
    from every estimate. Each distinct disparity value is its own histogram bin, so
    half-pixel disparities need no binning: a value ``v`` maps to
    ``round(223 * (cdf(v) - cdf(min)) / (n - cdf(min)))``, where ``cdf(v)`` counts the
    displayed pixels with a disparity ``<= v`` and ``n`` is their number.

    Parameters
    ----------
    disparity : ndarray, shape (H, W)
        Disparity in pixels, NaN where there is no estimate.
    occluded : ndarray of bool, shape (H, W), optional
        Pixels to draw white (e.g. :attr:`DisparityResult.occluded`). Pixels without a
        finite disparity are drawn white as well.

    Returns
    -------
    ndarray of uint8, shape (H, W)
        A map with a single finite value is drawn mid gray (112); an all-NaN map is white.

    Examples
    --------
    >>> paper_display(np.array([[0.0, 0.5, 2.0, np.nan]]))
    array([[  0, 112, 223, 255]], dtype=uint8)
    """
    d = disparity_array(disparity)
    hidden = ~np.isfinite(d)
    if occluded is not None:
        hidden |= _check_mask(occluded, d.shape, "occluded")
    out = np.full(d.shape, 255, dtype=np.uint8)
    shown = d[~hidden]
    if shown.size == 0:
        return out
    values, inverse, counts = np.unique(shown, return_inverse=True, return_counts=True)
    cdf = np.cumsum(counts)
    spread = shown.size - cdf[0]
    if spread == 0:
        levels = np.array([(PAPER_MAX_GRAY + 1) // 2], dtype=np.uint8)
    else:
        levels = np.rint(PAPER_MAX_GRAY * (cdf - cdf[0]) / spread).astype(np.uint8)
    out[~hidden] = levels[inverse.reshape(-1)]
    return out


def colorize(
    disparity: np.ndarray,
    *,
    vmin: float | None = None,
    vmax: float | None = None,
    cmap: str = "turbo",
    invalid: tuple[int, int, int] = (0, 0, 0),
) -> np.ndarray:
    """Colour a disparity map with a matplotlib colour map.

    Parameters
    ----------
    disparity : ndarray, shape (H, W)
        Disparity in pixels, NaN where there is no estimate.
    vmin, vmax : float, optional
        Disparities mapped to the ends of the colour map (values outside are clipped);
        default: the smallest and largest finite disparity. When they are equal every
        finite pixel gets the middle colour.
    cmap : str
        Name of a matplotlib colour map (``matplotlib.colormaps``).
    invalid : tuple of 3 int
        RGB colour of the pixels without a finite disparity.

    Returns
    -------
    ndarray of uint8, shape (H, W, 3)

    Examples
    --------
    >>> colorize(np.array([[1.0, np.nan]]), invalid=(255, 0, 255))[0, 1]
    array([255,   0, 255], dtype=uint8)
    """
    # lazy: matplotlib is slow to import and needed only here
    matplotlib = require("matplotlib", "plot", "colour maps")

    d = disparity_array(disparity)
    color = _check_color(invalid, "invalid")
    try:
        colormap = matplotlib.colormaps[cmap]
    except (KeyError, TypeError):
        raise ValueError(f"unknown matplotlib colour map {cmap!r}") from None
    finite = np.isfinite(d)
    out = np.empty(d.shape + (3,), dtype=np.uint8)
    out[...] = color
    if not finite.any():
        return out
    low = float(d[finite].min()) if vmin is None else _check_limit(vmin, "vmin")
    high = float(d[finite].max()) if vmax is None else _check_limit(vmax, "vmax")
    if low > high:
        given_low = f"vmin ({low:g})" if vmin is not None else f"the least value ({low:g})"
        given_high = f"vmax ({high:g})" if vmax is not None else f"the largest value ({high:g})"
        raise ValueError(f"{given_low} must not be larger than {given_high}")
    values = d[finite]
    if high == low:
        norm = np.full(values.shape, 0.5)
    else:
        # a value far outside the limits may overflow to +-inf: it is clipped all the same
        with np.errstate(over="ignore"):
            if np.isfinite(high - low):
                norm = (values - low) / (high - low)
            else:  # limits near the ends of float64: their difference overflows, halves do not
                norm = (values / 2 - low / 2) / (high / 2 - low / 2)
        norm = np.clip(norm, 0.0, 1.0)
    out[finite] = colormap(norm, bytes=True)[:, :3]
    return out


def error_map(
    disparity: np.ndarray,
    truth: np.ndarray,
    *,
    threshold: float = 1.0,
    mask: np.ndarray | None = None,
) -> np.ndarray:
    """Colour each pixel by how its disparity compares with the ground truth.

    Light gray (200): ``|disparity - truth| <= threshold``; red: a larger error; blue: no
    estimate (NaN) where the truth is known; black: not scored (truth NaN, or ``mask``
    False).

    Parameters
    ----------
    disparity, truth : ndarray, shape (H, W)
        Estimated and true disparity in pixels, NaN where unknown.
    threshold : float
        Largest error, in pixels, that counts as correct.
    mask : ndarray of bool, shape (H, W), optional
        Pixels to score; default all pixels with a finite truth.

    Returns
    -------
    ndarray of uint8, shape (H, W, 3)
    """
    d = disparity_array(disparity)
    gt = disparity_array(truth, "truth")
    if gt.shape != d.shape:
        raise ValueError(f"truth has shape {gt.shape} but disparity has shape {d.shape}")
    threshold = _check_limit(threshold, "threshold")
    if threshold < 0:
        raise ValueError(f"threshold must be 0 or more, got {threshold:g}")
    scored = np.isfinite(gt)
    if mask is not None:
        scored &= _check_mask(mask, d.shape, "mask")
    estimated = scored & np.isfinite(d)
    with np.errstate(over="ignore"):  # an error past float64's range is inf: still bad
        error = np.abs(np.where(estimated, d, 0.0) - np.where(estimated, gt, 0.0))
    out = np.empty(d.shape + (3,), dtype=np.uint8)
    out[...] = ERROR_UNSCORED
    out[scored & ~estimated] = ERROR_MISSING
    out[estimated & (error <= threshold)] = ERROR_GOOD
    out[estimated & (error > threshold)] = ERROR_BAD
    return out


def draw_points(
    image_rgb: np.ndarray,
    xs: np.ndarray,
    ys: np.ndarray,
    color: tuple[int, int, int] = (255, 0, 0),
    radius: int = 1,
) -> np.ndarray:
    """Draw filled squares of side ``2 * radius + 1`` centred on points, on a copy.

    Parameters
    ----------
    image_rgb : ndarray of uint8, shape (H, W, 3) or (H, W)
        The image; a gray image is drawn on as RGB.
    xs, ys : array_like, shape (M,)
        Column and row of each point, rounded to the nearest pixel. Squares are clipped
        at the image edges; points far outside draw nothing.
    color : tuple of 3 int
        RGB colour.
    radius : int
        Half side of the squares; 0 draws single pixels.

    Returns
    -------
    ndarray of uint8, shape (H, W, 3)
        A new image; the input is not modified.
    """
    image = np.asarray(image_rgb)
    if image.dtype != np.uint8:
        raise TypeError(f"image_rgb must be uint8, got dtype {image.dtype}")
    if image.ndim == 2:
        image = np.stack([image] * 3, axis=-1)
    elif not (image.ndim == 3 and image.shape[2] == 3):
        raise ValueError(f"image_rgb must have shape (H, W, 3) or (H, W), got {image.shape}")
    out = image.copy()
    color = _check_color(color, "color")
    if not is_integer(radius) or radius < 0:
        raise ValueError(f"radius must be an integer 0 or more, got {radius!r}")
    try:
        xs = np.asarray(xs, dtype=np.float64).reshape(-1)
        ys = np.asarray(ys, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise TypeError("xs and ys must hold numbers") from None
    if xs.shape != ys.shape:
        raise ValueError(f"xs and ys differ in length: {xs.size} vs {ys.size}")
    if not (np.isfinite(xs).all() and np.isfinite(ys).all()):
        raise ValueError("xs and ys must be finite")
    # Each square clipped to the image, in floats (a point may lie far outside, the radius
    # may be huge), then painted through a 2-D difference array: memory O(H * W + M).
    height, width = out.shape[:2]
    reach = float(min(radius, 2**62))
    cols, rows = np.rint(xs), np.rint(ys)
    top, bottom = np.maximum(rows - reach, 0), np.minimum(rows + reach, height - 1)
    first, last = np.maximum(cols - reach, 0), np.minimum(cols + reach, width - 1)
    keep = (top <= bottom) & (first <= last)
    top, bottom, first, last = (a[keep].astype(np.int64) for a in (top, bottom, first, last))
    marks = np.zeros((height + 1, width + 1), dtype=np.int64)
    np.add.at(marks, (top, first), 1)
    np.add.at(marks, (top, last + 1), -1)
    np.add.at(marks, (bottom + 1, first), -1)
    np.add.at(marks, (bottom + 1, last + 1), 1)
    painted = marks.cumsum(axis=0).cumsum(axis=1)[:height, :width] > 0
    out[painted] = color
    return out


def preview(
    disparity: np.ndarray, occluded: np.ndarray | None = None, *, style: str = "paper"
) -> np.ndarray:
    """Quick look at a disparity map.

    Parameters
    ----------
    disparity : ndarray, shape (H, W)
        Disparity in pixels, NaN where there is no estimate.
    occluded : ndarray of bool, shape (H, W), optional
        Pixels to show as occluded.
    style : {"paper", "color"}
        ``"paper"``: :func:`paper_display`, uint8 (H, W); ``"color"``: :func:`colorize`
        with occluded and NaN pixels black, uint8 (H, W, 3).

    Returns
    -------
    ndarray of uint8
    """
    check_preview_style(style)
    if style == "paper":
        return paper_display(disparity, occluded)
    d = disparity_array(disparity)
    if occluded is not None:
        d = np.where(_check_mask(occluded, d.shape, "occluded"), np.nan, d)
    return colorize(d)


def _check_mask(mask: np.ndarray, shape: tuple[int, ...], name: str) -> np.ndarray:
    m = np.asarray(mask)
    if m.dtype != np.bool_:
        raise TypeError(f"{name} must be a bool array, got dtype {m.dtype}")
    if m.shape != shape:
        raise ValueError(f"{name} has shape {m.shape} but disparity has shape {shape}")
    return m


def _check_color(color: tuple[int, int, int], name: str) -> np.ndarray:
    c = np.asarray(color)
    if c.shape != (3,) or c.dtype.kind not in "iu" or c.min() < 0 or c.max() > 255:
        raise ValueError(f"{name} must be three integers in 0..255, got {color!r}")
    return c.astype(np.uint8)


def _check_limit(value: float, name: str) -> float:
    if not is_number(value):
        raise TypeError(f"{name} must be a number, got {type(value).__name__}")
    if not np.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value}")
    return float(value)


# --- Rerun -------------------------------------------------------------------------------

#: The entity paths :func:`log_rerun` writes (Rerun's ``/``-separated paths).
RERUN_ENTITIES = {
    "world": "the 3-D space, X right, Y down, Z forward (static; with a calibration)",
    "world/camera": "the left camera's pinhole, from the calibration",
    "world/camera/image": "the left image",
    "world/camera/image/features": "the reliable feature pairs of the dc methods (2-D points)",
    "world/camera/depth": "the depth (a depth image, shown in 3-D through the camera)",
    "world/points": "the coloured point cloud",
    "disparity": "the disparity in colour (turbo over the searched range; black: none)",
    "occlusion": "why a pixel has no estimate: occluded (1), beyond the border (2) or "
    "a mismatch (3, sgm's left-right check)",
    "confidence": "the confidence in colour (viridis over 0..1; black: none)",
}

#: The classes of the ``occlusion`` segmentation image: id, label, RGBA colour.
OCCLUSION_CLASSES = (
    (0, "estimate", (0, 0, 0, 0)),
    (1, "occluded", (255, 255, 255, 255)),
    (2, "border", (128, 128, 128, 255)),
    (3, "mismatch", (255, 0, 255, 255)),
)

_LOG = logging.getLogger(__name__)


def _import_rerun():
    try:
        import rerun
    except ImportError as err:
        raise ImportError(
            'Rerun is not installed; install the extra: pip install "dcstereo[rerun]"'
        ) from err
    return rerun


@contextlib.contextmanager
def rerun_recording(
    path: str | os.PathLike | None = None,
    *,
    spawn: bool = False,
    application_id: str = "dcstereo",
) -> Iterator["object"]:
    """Open a Rerun recording of its own, saved to a file or streamed to a viewer.

    A dedicated ``rerun.RecordingStream`` (never Rerun's global one: nothing changes for
    the rest of the program) for :func:`log_rerun`'s ``recording=``. When the block ends
    the recording is flushed and closed; the file is written atomically, moved onto
    ``path`` only when the block ends without an error.

    Parameters
    ----------
    path : str or os.PathLike, optional
        The ``.rrd`` file to save the recording to (open it with ``rerun FILE.rrd``).
    spawn : bool
        Also start a Rerun viewer (the ``rerun`` program of the ``rerun-sdk`` package)
        and stream the recording to it. A viewer that cannot be reached is logged as a
        warning (``logging``) when the recording closes, not raised: the file is complete.
    application_id : str
        The recording's application id (the viewer groups recordings by it).

    Yields
    ------
    rerun.RecordingStream

    Raises
    ------
    ImportError
        When ``rerun-sdk`` is not installed (the message names the extra).
    ValueError
        For a path that does not end in ``.rrd`` or cannot be written, or neither a path
        nor ``spawn``.

    Examples
    --------
    >>> with rerun_recording("match.rrd") as recording:  # doctest: +SKIP
    ...     log_rerun(result, left, recording=recording, calibration=calib)
    """
    from dcstereo import io

    if path is None and not spawn:
        raise ValueError("give the recording a path (an .rrd file) or spawn=True (a viewer)")
    if path is not None and not os.fspath(path).lower().endswith(".rrd"):
        raise ValueError(f"a Rerun recording is an .rrd file, got '{os.fspath(path)}'")
    if not isinstance(spawn, bool):
        raise TypeError(f"spawn must be True or False, got {spawn!r}")
    rr = _import_rerun()
    with contextlib.ExitStack() as stack:
        target = None if path is None else stack.enter_context(io.atomic_write(path))
        recording = rr.RecordingStream(application_id)
        sinks = []
        if spawn:
            sinks.append(_viewer_sink(rr, recording))
        if target is not None:
            sinks.append(rr.FileSink(str(target)))
        recording.set_sinks(*sinks)
        try:
            yield recording
        finally:
            try:
                recording.flush()
            except RuntimeError as err:  # the viewer went away: the file sink is done
                _LOG.warning("the Rerun viewer could not be reached: %s", err)
            recording.disconnect()


def _viewer_sink(rr, recording):
    """Start a Rerun viewer; return the sink that streams to it.

    The viewer is the ``rerun`` program of this environment's ``rerun-sdk`` (found beside
    the Python interpreter, so that an environment that is not activated works), else the
    first on the ``PATH``.
    """
    here = shutil.which("rerun", path=os.path.dirname(sys.executable))
    try:
        rr.spawn(connect=False, recording=recording, executable_path=here)
    except RuntimeError as err:  # no viewer program, or it did not start
        raise ValueError(f"cannot start the Rerun viewer: {err}") from None
    return rr.GrpcSink()


def log_rerun(
    result,
    left: np.ndarray | None = None,
    *,
    recording=None,
    calibration=None,
    confidence: np.ndarray | None = None,
    occluded: np.ndarray | None = None,
    disparity_range: tuple[float, float] | None = None,
    frame: int | None = None,
    timeline: str = "frame",
    meter: float = 1.0,
) -> None:
    """Log a matching result to Rerun: images, disparity, occlusions, depth and points.

    The entities are :data:`RERUN_ENTITIES`: the left image (``world/camera/image``, with
    the ``dc`` methods' feature pairs as 2-D points), the disparity in colour
    (``disparity``), why pixels have no estimate (``occlusion``, a segmentation image
    labelled by :data:`OCCLUSION_CLASSES`), the confidence (``confidence``) and, given a
    calibration, the left camera's pinhole (``world/camera``), the depth
    (``world/camera/depth``, which the viewer also shows in 3-D through the camera) and
    the coloured point cloud (``world/points``) in the camera's frame (X right, Y down,
    Z forward, :func:`dcstereo.geometry.point_cloud`).

    Parameters
    ----------
    result : DisparityResult or ndarray of float, shape (H, W)
        The result of :func:`dcstereo.match`, or a disparity map alone (NaN = none).
    left : ndarray, shape (H, W) or (H, W, 3|4), optional
        The left image (RGB order): the image entity and the points' colours.
    recording : rerun.RecordingStream, optional
        Where to log (:func:`rerun_recording`); default Rerun's current recording (the
        one ``rerun.init`` made), and an error when there is none.
    calibration : dcstereo.geometry.Calibration, optional
        The pair's geometry: the camera, the depth and the point cloud.
    confidence : ndarray of float, shape (H, W), optional
        :func:`dcstereo.refine.confidence.confidence` of the result.
    occluded : ndarray of bool, shape (H, W), optional
        With a disparity map for ``result``: its occluded pixels (default its NaN pixels).
    disparity_range : (float, float), optional
        The disparities at the two ends of the colour map; default the range searched
        (the result's parameters), or the map's least and largest value.
    frame : int, optional
        The time of this log on ``timeline`` (a sequence's frame index); None logs at the
        recording's current time.
    timeline : str
        The name of the time line of ``frame``.
    meter : float
        How many units of the baseline make a metre (1000 for Middlebury's
        millimetres): depth and points are logged in metres, Rerun's unit. Default 1: in
        the baseline's unit.

    Raises
    ------
    ImportError
        When ``rerun-sdk`` is not installed (the message names the extra).
    TypeError, ValueError
        For arrays of other shapes or types, or no recording.

    Examples
    --------
    >>> with rerun_recording("tsukuba.rrd") as recording:  # doctest: +SKIP
    ...     log_rerun(result, left, recording=recording, confidence=sure, frame=0)
    """
    from dcstereo.geometry import Calibration, depth, point_cloud
    from dcstereo.result import FLAG_BORDER, FLAG_MISMATCH, FLAG_OCCLUDED, DisparityResult

    flags = None
    features = None
    if isinstance(result, DisparityResult):
        if occluded is not None:
            raise ValueError("occluded is given by the result's flags; pass it with a map only")
        disparity = result.disparity
        flags = result.flags
        features = result.features
        if disparity_range is None:
            disparity_range = (result.params.min_disparity, result.params.max_disparity)
    else:
        disparity = disparity_array(result, "result").astype(np.float32)
    shape = disparity.shape
    if occluded is not None:
        occluded = _check_mask(occluded, shape, "occluded")
    if left is not None:
        left = np.asarray(left)
        if left.shape[:2] != shape or left.ndim not in (2, 3):
            raise ValueError(f"left has shape {left.shape}, the disparity {shape}")
    if confidence is not None:
        confidence = disparity_array(confidence, "confidence")
        if confidence.shape != shape:
            raise ValueError(f"confidence has shape {confidence.shape}, the disparity {shape}")
    if calibration is not None and not isinstance(calibration, Calibration):
        raise TypeError(
            f"calibration must be a dcstereo.geometry.Calibration, got {type(calibration).__name__}"
        )
    if frame is not None and not is_integer(frame):
        raise TypeError(f"frame must be an integer, got {frame!r}")
    if not isinstance(timeline, str) or not timeline:
        raise ValueError(f"timeline must be a non-empty name, got {timeline!r}")
    meter = _check_limit(meter, "meter")
    if meter <= 0:
        raise ValueError(f"meter must be positive, got {meter:g}")
    low, high = (None, None) if disparity_range is None else disparity_range
    if disparity_range is not None:
        low, high = _check_limit(low, "disparity_range"), _check_limit(high, "disparity_range")
    rr = _import_rerun()
    if recording is None:
        recording = rr.get_data_recording()
        if recording is None:
            raise ValueError(
                "no Rerun recording: pass recording= (dcstereo.viz.rerun_recording) or call "
                "rerun.init() first"
            )
    elif not isinstance(recording, rr.RecordingStream):
        raise TypeError(
            f"recording must be a rerun.RecordingStream, got {type(recording).__name__}"
        )

    if frame is not None:
        recording.set_time(timeline, sequence=int(frame))
    classes = [
        rr.AnnotationInfo(id=i, label=label, color=color) for i, label, color in OCCLUSION_CLASSES
    ]
    recording.log("occlusion", rr.AnnotationContext(classes), static=True)
    if left is not None:
        recording.log("world/camera/image", rr.Image(left))
    if features is not None and len(features):
        recording.log(
            "world/camera/image/features",
            # Rerun's pixel (x, y) spans x..x+1, y..y+1: the points at the pixels' centres
            rr.Points2D(features[:, [1, 0]] + 0.5, colors=(255, 0, 0), radii=1.0),
        )
    recording.log("disparity", rr.Image(colorize(disparity, vmin=low, vmax=high)))
    classes_image = np.zeros(shape, dtype=np.uint8)
    if flags is not None:
        classes_image[(flags & FLAG_OCCLUDED) != 0] = 1
        classes_image[(flags & FLAG_MISMATCH) != 0] = 3
        classes_image[(flags & FLAG_BORDER) != 0] = 2
    else:
        classes_image[~np.isfinite(disparity) if occluded is None else occluded] = 1
    recording.log("occlusion", rr.SegmentationImage(classes_image))
    if confidence is not None:
        picture = colorize(confidence, vmin=0.0, vmax=1.0, cmap="viridis")
        recording.log("confidence", rr.Image(picture))
    if calibration is None:
        return
    recording.log("world", rr.ViewCoordinates.RDF, static=True)
    recording.log(
        "world/camera",
        rr.Pinhole(
            image_from_camera=[
                [calibration.focal, 0.0, calibration.cx],
                [0.0, calibration.fy, calibration.cy],
                [0.0, 0.0, 1.0],
            ],
            resolution=[shape[1], shape[0]],
            camera_xyz=rr.ViewCoordinates.RDF,
        ),
    )
    z = depth(disparity, calibration)
    # Rerun reads a depth of 0 as none; a NaN it might draw
    recording.log("world/camera/depth", rr.DepthImage(np.nan_to_num(z, nan=0.0), meter=meter))
    colors = None if left is None else _point_colors(left)
    cloud = point_cloud(disparity, calibration, colors)
    recording.log(
        "world/points",
        rr.Points3D(cloud.points / np.float32(meter), colors=cloud.colors),
    )


def _point_colors(left: np.ndarray) -> np.ndarray | None:
    """Return the left image as :func:`~dcstereo.geometry.point_cloud` takes colours."""
    if left.ndim == 3:
        left = left[:, :, :3]
    if left.dtype.kind == "f":
        return np.rint(np.clip(np.nan_to_num(left), 0.0, 1.0) * 255).astype(np.uint8)
    if left.dtype in (np.uint8, np.uint16):
        return left
    return None
