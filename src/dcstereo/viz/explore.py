"""Figures on real data: the method comparison (Fig. 4 / 6) and the scanline view (Fig. 1 / 2).

:func:`compare_methods` runs several methods on one pair and :func:`compare_figure` lays
their maps side by side: the paper's display (histogram-equalized, occlusions white), the
filled map in colour and, with ground truth, an error map. :func:`scanline` gathers what
one scanline looks like to the matchers: the disparity-space image of eq. 4 of that row,
the optimal paths of ``dsi3`` and ``dsi5``, the feature pairs ``dc`` accepted and the two
intensity profiles; :func:`scanline_figure` draws it.
"""

from collections.abc import Sequence

import numpy as np

from dcstereo import viz
from dcstereo._checks import is_integer, is_number
from dcstereo._extras import require
from dcstereo.params import SGM_METHODS, base_method, check_method_options, options_for
from dcstereo.signal import check_image, check_pair, intensity

#: Methods of :func:`compare_methods` and :func:`scanline` by default (the paper's Fig. 4).
PAPER_METHODS = ("dsi3", "dsi5", "dc")

#: Smallest and largest side, in pixels, of a :func:`scanline_figure` picture (smaller
#: leaves no room for the axes; the picture is drawn in memory, 4 bytes a pixel).
FIGURE_SIDES = (200, 10000)

_CAPTION = 16  # pixels of the caption strip above each panel
_GAP = 4  # white pixels between panels


def _check_methods(methods) -> None:
    if isinstance(methods, str):
        raise TypeError(f"methods must be a sequence of method names, got the string {methods!r}")


def _gray_rgb(image: np.ndarray) -> np.ndarray:
    value = np.clip(np.rint(intensity(image)), 0, 255).astype(np.uint8)
    return np.stack([value] * 3, axis=-1)


def _rgb(picture: np.ndarray) -> np.ndarray:
    return picture if picture.ndim == 3 else np.stack([picture] * 3, axis=-1)


def _captioned(panel: np.ndarray, caption: str) -> np.ndarray:
    from PIL import Image, ImageDraw

    height, width = panel.shape[:2]
    canvas = Image.new("RGB", (width, height + _CAPTION), (255, 255, 255))
    canvas.paste(Image.fromarray(_rgb(panel)), (0, _CAPTION))
    ImageDraw.Draw(canvas).text((2, 2), caption, fill=(0, 0, 0))
    return np.asarray(canvas)


def compare_methods(
    left: np.ndarray,
    right: np.ndarray,
    *,
    max_disparity: int,
    methods: Sequence[str] = PAPER_METHODS,
    min_disparity: int = 0,
    match_options: dict | None = None,
    **options,
) -> dict:
    """Run each method on the pair (see :func:`dcstereo.evaluation.run_method`).

    Parameters
    ----------
    left, right : ndarray
        The rectified pair.
    max_disparity, min_disparity : int
        Inclusive search range.
    methods : sequence of str
        Method names, :data:`dcstereo.params.METHODS` or ``opencv-sgbm`` / ``opencv-bm``.
    match_options : dict, optional
        Passed to dcstereo's methods only, not to OpenCV's. Each method's own parameters
        (``ser_min`` and the others of :data:`dcstereo.params.METHOD_OPTIONS`) go to the
        methods that read them; one that none of ``methods`` reads is refused
        (``ValueError``).
    **options
        Passed to every method.

    Returns
    -------
    dict of str to DisparityResult
        In the order of ``methods``; results are not filled.
    """
    from dcstereo.evaluation.scoring import OPENCV_METHODS, run_method

    _check_methods(methods)
    ours = {**options, **(match_options or {})}
    check_method_options(ours, methods)
    return {
        method: run_method(
            method,
            left,
            right,
            max_disparity=max_disparity,
            min_disparity=min_disparity,
            **(options if method in OPENCV_METHODS else options_for(method, ours)),
        )
        for method in methods
    }


def compare_figure(
    left: np.ndarray,
    results: dict,
    *,
    max_disparity: float,
    truth: np.ndarray | None = None,
    mask: np.ndarray | None = None,
    threshold: float = 1.0,
) -> np.ndarray:
    """Lay out the left image and each method's maps, one column per method.

    Rows: the paper's display (:func:`dcstereo.viz.paper_display`, occlusions white),
    the filled map in colour (turbo, ``0..max_disparity`` for every panel) and, when
    ``truth`` is given, the error map of the filled map (:func:`dcstereo.viz.error_map`:
    gray correct, red wrong by more than ``threshold``, black not scored). The first
    column holds the left image, then the ground truth in the same two displays. Each
    panel has a caption: the method and, with ground truth, its bad-``threshold`` rate
    over the scored pixels (filled map).

    Parameters
    ----------
    left : ndarray, shape (H, W) or (H, W, 3)
        The left image.
    results : dict of str to DisparityResult
        From :func:`compare_methods`.
    max_disparity : float
        Top of the colour scale.
    truth : ndarray, shape (H, W), optional
        Ground truth, NaN where unknown.
    mask : ndarray of bool, shape (H, W), optional
        Pixels scored by the error maps; all with known truth by default.
    threshold : float
        Error tolerance of the error maps, in pixels.

    Returns
    -------
    ndarray of uint8, shape (rows * (H + 16), (1 + len(results)) * (W + 4) - 4, 3)
    """
    from dcstereo.evaluation.metrics import bad_pixel_rate
    from dcstereo.result import DisparityResult

    left = check_image(left, "left")
    height, width = left.shape[:2]
    if not results:
        raise ValueError("no method to show")
    for method, result in results.items():
        if not isinstance(result, DisparityResult):
            raise TypeError(
                f"results[{method!r}] must be a DisparityResult, got {type(result).__name__}"
            )
        if result.disparity.shape != (height, width):
            raise ValueError(
                f"results[{method!r}] has shape {result.disparity.shape}, the left image "
                f"{(height, width)}"
            )
    if not is_number(max_disparity):
        raise TypeError(f"max_disparity must be a number, got {type(max_disparity).__name__}")
    if not (np.isfinite(max_disparity) and max_disparity >= 0):
        raise ValueError(f"max_disparity must be a finite number 0 or more, got {max_disparity}")
    if truth is not None and np.shape(truth) != (height, width):
        raise ValueError(
            f"the ground truth has shape {np.shape(truth)}, the images {(height, width)}"
        )
    colour = {"vmin": 0.0, "vmax": float(max_disparity)}
    blank = np.full((height, width, 3), 255, np.uint8)
    first = [_captioned(_gray_rgb(left), "left")]
    if truth is None:
        first.append(_captioned(blank, ""))
    else:
        first.append(_captioned(viz.colorize(truth, **colour), "ground truth"))
        first.append(_captioned(blank, "errors: gray ok, red bad, black unscored"))
    columns = [first]
    for method, result in results.items():
        dense = result.filled().disparity
        caption = method
        if truth is not None:
            rate = bad_pixel_rate(dense, truth, mask=mask, threshold=threshold)
            caption = f"{method}  bad-{threshold:g} {rate:.1f}%"
        column = [
            _captioned(viz.paper_display(result.disparity, result.occluded), caption),
            _captioned(viz.colorize(dense, **colour), f"{method} filled"),
        ]
        if truth is not None:
            column.append(
                _captioned(
                    viz.error_map(dense, truth, threshold=threshold, mask=mask),
                    f"{method} errors > {threshold:g} px",
                )
            )
        columns.append(column)
    rows = []
    for index in range(len(columns[0])):
        parts = []
        for column in columns:
            parts += [column[index], np.full((height + _CAPTION, _GAP, 3), 255, np.uint8)]
        rows.append(np.concatenate(parts[:-1], axis=1))
    return np.concatenate(rows, axis=0)


def dsi_row(
    left: np.ndarray,
    right: np.ndarray,
    row: int,
    *,
    max_disparity: int,
    min_disparity: int = 0,
    window: int = 5,
) -> np.ndarray:
    """Compute the disparity-space image (eq. 4) of one scanline as a mean absolute difference.

    ``dsi[k, x]`` is the mean over the ``window x window`` square of
    ``|I_L(x + i, row + j) - I_R(x - d + i, row + j)|`` for ``d = min_disparity + k``, on
    the 0..255 intensity (luma) scale, images edge-replicated outside; NaN where the
    partner ``x - d`` is outside the right image. A plain numpy twin of the matcher's
    cost, for display.

    Parameters
    ----------
    left, right : ndarray, shape (H, W) or (H, W, 3)
        The rectified pair.
    row : int
        The scanline, ``0 <= row < H``.
    max_disparity, min_disparity : int
        Inclusive disparity range; it must fit the image as for :func:`dcstereo.match`
        (``-W < min_disparity <= max_disparity < W``).
    window : int
        Odd window side, at most the image's height and width.

    Returns
    -------
    ndarray of float64, shape (max_disparity - min_disparity + 1, W)
    """
    from dcstereo.params import MatchParams

    left, right = check_pair(left, right)
    height, width = left.shape[:2]
    if not is_integer(row):
        raise TypeError(f"row must be an integer, got {row!r}")
    if not 0 <= row < height:
        raise ValueError(f"row must be in 0..{height - 1}, got {row}")
    # the checks of dcstereo.match: integers, an odd window, a range that fits the width
    params = MatchParams(max_disparity=max_disparity, min_disparity=min_disparity, window=window)
    params.check_image_size(height, width)
    max_disparity, min_disparity, window = (
        params.max_disparity,
        params.min_disparity,
        params.window,
    )
    radius = window // 2
    pad = ((radius, radius), (radius, radius))
    band = slice(row, row + window)  # rows row-r..row+r of the padded images
    lp = np.pad(intensity(left), pad, mode="edge")[band]
    rp = np.pad(intensity(right), pad, mode="edge")[band]
    disparities = np.arange(min_disparity, max_disparity + 1)
    dsi = np.full((disparities.size, width), np.nan)
    columns = np.arange(width + 2 * radius)
    for k, d in enumerate(disparities):
        source = np.clip(columns - d, 0, width + 2 * radius - 1)
        diff = np.abs(lp - rp[:, source]).sum(axis=0)
        sums = np.convolve(diff, np.ones(window), mode="valid")  # window sums at x = 0..W-1
        cost = sums / (window * window)
        x = np.arange(width)
        valid = (x - d >= 0) & (x - d < width)
        dsi[k, valid] = cost[valid]
    return dsi


def scanline(
    left: np.ndarray,
    right: np.ndarray,
    row: int,
    *,
    max_disparity: int,
    min_disparity: int = 0,
    window: int = 5,
    methods: Sequence[str] = PAPER_METHODS,
    **options,
) -> dict:
    """Everything :func:`scanline_figure` draws for one row.

    The methods run on the band of rows ``row - window // 2 .. row + window // 2`` (the
    rows the window of ``row`` reaches; at the image edges, the first or last ``window``
    rows), which gives the row the same disparities as a run on the whole image, because
    rows are matched independently.

    Parameters
    ----------
    left, right : ndarray
        The rectified pair.
    row : int
        The scanline.
    max_disparity, min_disparity, window : int
        As for :func:`dcstereo.match`.
    methods : sequence of str
        Methods whose path is drawn (names as for
        :func:`dcstereo.evaluation.run_method`: a ``+bt`` suffix for the
        Birchfield-Tomasi cost); feature pairs come from the ``dc`` methods.
    **options
        Passed to :func:`dcstereo.match`; each method's own parameters only to the methods
        that read them (one that none of ``methods`` reads: ``ValueError``).

    Returns
    -------
    dict
        ``row``, ``min_disparity``, ``max_disparity``, ``dsi`` (from :func:`dsi_row`),
        ``paths`` (method -> disparity of the row, NaN where occluded), ``features``
        (method -> (M, 2) array of ``(x_left, x_right)``), ``left_profile`` and
        ``right_profile`` (intensity of the row, 0..255).
    """
    from dcstereo.evaluation.scoring import run_method

    _check_methods(methods)
    if any(base_method(m) in SGM_METHODS for m in methods):
        raise ValueError(
            "sgm and sgm-accurate have no scanline path to draw (their costs are aggregated "
            "across the rows); choose scanline methods"
        )
    check_method_options(options, methods)
    dsi = dsi_row(
        left,
        right,
        row,
        max_disparity=max_disparity,
        min_disparity=min_disparity,
        window=window,
    )
    radius = window // 2
    height = np.shape(left)[0]
    # At least `window` rows (match refuses fewer); more rows change nothing for `row`.
    top = max(0, min(row - radius, height - window))
    bottom = min(height, max(row + radius + 1, top + window))
    paths, features = {}, {}
    for method in methods:
        result = run_method(
            method,
            left[top:bottom],
            right[top:bottom],
            max_disparity=max_disparity,
            min_disparity=min_disparity,
            window=window,
            **options_for(method, options),
        )
        paths[method] = result.disparity[row - top].astype(np.float64)
        if result.features is not None:
            mine = result.features[result.features[:, 0] == row - top]
            features[method] = mine[:, 1:3].copy()
    return {
        "row": row,
        "min_disparity": min_disparity,
        "max_disparity": max_disparity,
        "dsi": dsi,
        "paths": paths,
        "features": features,
        "left_profile": intensity(check_image(left, "left"))[row],
        "right_profile": intensity(check_image(right, "right"))[row],
    }


_PATH_COLOURS = ("tab:red", "tab:cyan", "tab:orange", "tab:green", "tab:purple", "tab:pink")


def scanline_figure(data: dict, *, width: int = 1200, height: int = 800) -> np.ndarray:
    """Draw a :func:`scanline` record (the paper's Fig. 1 and 2 on real data).

    Top: the DSI of the row (``x_left`` across, disparity up; dark = good match; cells
    whose partner is outside the right image are white) with the optimal path of each
    method (occluded pixels have no point) and the accepted feature pairs of the ``dc``
    methods as yellow circles. Bottom: the intensity profiles of the left and the right
    row.

    Parameters
    ----------
    data : dict
        From :func:`scanline`.
    width, height : int
        Size of the picture in pixels, each in :data:`FIGURE_SIDES` (200 to 10000).

    Returns
    -------
    ndarray of uint8, shape (height, width, 3)
    """
    matplotlib = require("matplotlib", "plot", "figures")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    low, high = FIGURE_SIDES
    for name, value in (("width", width), ("height", height)):
        if not is_integer(value):
            raise TypeError(f"{name} must be an integer, got {value!r}")
        if not low <= value <= high:
            raise ValueError(f"{name} must be {low} to {high} pixels, got {value}")
    dsi = data["dsi"]
    dmin, dmax = data["min_disparity"], data["max_disparity"]
    columns = dsi.shape[1]
    figure = Figure(figsize=(width / 100, height / 100), dpi=100)
    canvas = FigureCanvasAgg(figure)
    top, bottom = figure.subplots(2, 1, height_ratios=(3, 1), sharex=True)
    finite = dsi[np.isfinite(dsi)]
    high = float(np.percentile(finite, 99)) if finite.size else 1.0
    cmap = matplotlib.colormaps["gray"].with_extremes(bad="white")
    top.imshow(
        np.ma.masked_invalid(dsi),
        cmap=cmap,
        vmin=0.0,
        vmax=max(high, 1e-9),
        origin="lower",
        aspect="auto",
        extent=(-0.5, columns - 0.5, dmin - 0.5, dmax + 0.5),
        interpolation="nearest",
    )
    xs = np.arange(columns)
    sizes = np.linspace(7, 2, max(len(data["paths"]), 1))  # later paths on top, smaller
    for index, (method, path) in enumerate(data["paths"].items()):
        shown = np.isfinite(path)
        colour = _PATH_COLOURS[index % len(_PATH_COLOURS)]
        top.plot(xs[shown], path[shown], "o", color=colour, markersize=sizes[index], label=method)
    for method, pairs in data["features"].items():
        if len(pairs):
            top.plot(
                pairs[:, 0],
                pairs[:, 0] - pairs[:, 1],
                "o",
                markerfacecolor="none",
                markeredgecolor="yellow",
                markersize=7,
                label=f"{method} feature pairs",
            )
    top.set_ylabel("disparity d = xL - xR (px)")
    top.set_title(f"row {data['row']}: DSI (mean |IL - IR| over the window) and optimal paths")
    top.legend(loc="upper right", fontsize=8)
    bottom.plot(xs, data["left_profile"], color="tab:blue", linewidth=1, label="left")
    bottom.plot(xs, data["right_profile"], color="tab:orange", linewidth=1, label="right")
    bottom.set_xlabel("x (px)")
    bottom.set_ylabel("intensity")
    bottom.legend(loc="upper right", fontsize=8)
    bottom.set_xlim(-0.5, columns - 0.5)
    figure.tight_layout()
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[:, :, :3].copy()
