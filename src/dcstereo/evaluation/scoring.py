"""Score disparity maps against Middlebury ground truth, and benchmark methods over scenes.

Used by ``dcstereo eval``, ``dcstereo bench`` and ``scripts/make_results.py``. The numbers
come from :func:`dcstereo.evaluation.metrics.evaluate`: the denominator of every rate is the masked
pixels with known ground truth, and a pixel without an estimate counts as bad (Middlebury
v3). Each method is scored twice: as it comes (``"sparse"``, with its density) and after
the project's hole filling, :meth:`DisparityResult.filled` (``"dense"``), which is applied
to every method alike, OpenCV's included.
"""

import io
import json
import math
import os
import platform
import time
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dcstereo.compat.opencv import OPENCV_METHODS
from dcstereo.costs import photometric
from dcstereo.evaluation.datasets import (
    MASK_SOURCES,
    MISSING_MASKS,
    StereoScene,
    find_scenes,
    load_scene,
    scene_layout,
)
from dcstereo.evaluation.metrics import DEFAULT_THRESHOLDS, KITTI_THRESHOLDS, bad_key, evaluate
from dcstereo.params import BT_SUFFIX, METHODS, base_method, check_method_options, options_for
from dcstereo.result import DisparityResult

#: Order of the masks in reports.
MASK_ORDER = ("nonocc", "all", "disc")


def opencv_available() -> bool:
    """Whether ``cv2`` can be imported."""
    try:
        import cv2  # noqa: F401
    except ImportError:
        return False
    return True


def available_methods(include_opencv: bool | None = None) -> list[str]:
    """Every method :func:`run_method` knows: :data:`dcstereo.params.METHODS`, then OpenCV's.

    Parameters
    ----------
    include_opencv : bool, optional
        Add ``opencv-sgbm`` and ``opencv-bm``; default when OpenCV is installed.

    Returns
    -------
    list of str
    """
    if include_opencv is None:
        include_opencv = opencv_available()
    return list(METHODS) + (list(OPENCV_METHODS) if include_opencv else [])


def parse_methods(text: str | None) -> list[str]:
    """Turn ``"dc,dsi5"`` into a checked list of names; None or ``"all"``: every method.

    Parameters
    ----------
    text : str or None
        Comma-separated method names.

    Returns
    -------
    list of str

    Raises
    ------
    ValueError
        For an unknown or repeated name, or an empty list.
    """
    if text is None or text.strip() == "all":
        return available_methods()
    names = [part.strip() for part in text.split(",") if part.strip()]
    known = list(METHODS) + list(OPENCV_METHODS)
    for name in names:
        if name not in known and not _bt_method(name):
            raise ValueError(
                f"unknown method {name!r}; choose from {', '.join(known)} "
                f"(a name of {', '.join(m for m in METHODS if m != 'redert')} may end in "
                f"{BT_SUFFIX!r} to match with the Birchfield-Tomasi cost)"
            )
    if len(set(names)) != len(names):
        raise ValueError(f"a method is repeated in {text!r}")
    if not names:
        raise ValueError("no method given")
    return names


def _bt_method(name: str) -> bool:
    """Whether ``name`` is a method of ours (not redert) with :data:`BT_SUFFIX`."""
    base = base_method(name)
    return name.endswith(BT_SUFFIX) and base in METHODS and base != "redert"


def run_method(
    method: str, left: np.ndarray, right: np.ndarray, *, max_disparity: int, **options
) -> DisparityResult:
    """Run one method by name: :func:`dcstereo.match` or OpenCV's (``match_opencv``).

    Parameters
    ----------
    method : str
        A name of :func:`available_methods`; a name of ours ending in :data:`BT_SUFFIX`
        runs that method with ``cost="bt"`` (Birchfield-Tomasi).
    left, right : ndarray
        The rectified pair.
    max_disparity : int
        Largest disparity searched.
    **options
        Passed on (``min_disparity``, ``window``, ...).

    Returns
    -------
    DisparityResult
        As the method gives it (not filled).
    """
    if method in OPENCV_METHODS:
        from dcstereo.compat.opencv import match_opencv

        settings: dict[str, Any] = dict(OPENCV_METHODS[method])
        if settings["method"] == "sgbm":
            settings["colour"] = np.ndim(left) == 3 and np.ndim(right) == 3
        return match_opencv(left, right, max_disparity=max_disparity, **settings, **options)
    from dcstereo.api import match

    if _bt_method(method):
        method = base_method(method)
        options = {**options, "cost": "bt"}
    return match(left, right, max_disparity=max_disparity, method=method, **options)


def score(
    disparity: np.ndarray,
    scene: StereoScene,
    thresholds: Sequence[float] = DEFAULT_THRESHOLDS,
) -> dict[str, dict[str, float]]:
    """All metrics of one disparity map against a scene, for each of its masks.

    Parameters
    ----------
    disparity : ndarray, shape (H, W)
        Estimate in pixels, NaN where there is none.
    scene : StereoScene
        Ground truth and masks.
    thresholds : sequence of float
        Bad-pixel thresholds.

    Returns
    -------
    dict
        ``{mask: {"bad-0.5": %, ..., "mae": px, "rms": px, "density": %}}``, masks in the
        order of :data:`MASK_ORDER`; ``mae`` and ``rms`` are NaN where the map has no
        estimate in the mask (``null`` in :func:`to_json`). A KITTI scene
        (``scene.meta["kitti"]``) has KITTI's measures too: ``"d1"`` first and bad-2.0,
        bad-3.0 and bad-4.0 (:data:`dcstereo.evaluation.metrics.KITTI_THRESHOLDS`).

    Raises
    ------
    ValueError
        When the map and the scene differ in size.
    """
    disparity = np.asarray(disparity)
    if disparity.shape != scene.shape:
        raise ValueError(
            f"the prediction is {disparity.shape[-1]}x{disparity.shape[0]} pixels but scene "
            f"{scene.name} is {scene.shape[1]}x{scene.shape[0]}"
        )
    names = [m for m in MASK_ORDER if m in scene.masks]
    names += [m for m in scene.masks if m not in names]
    # KITTI's D1 and bad-2/3/4 too (dcstereo.evaluation.kitti)
    kitti = bool(scene.meta.get("kitti"))
    if kitti:
        thresholds = sorted({*thresholds, *KITTI_THRESHOLDS})
    masks = {m: scene.masks[m] for m in names}
    return evaluate(disparity, scene.disparity, masks, thresholds, d1=kitti)


def scene_masks(scene: StereoScene) -> dict:
    """Say which masks a scene is scored on, where each comes from, and which it lacks.

    Parameters
    ----------
    scene : StereoScene
        A scene from :func:`dcstereo.evaluation.datasets.load_scene` (or built by hand:
        its masks are then described by name only).

    Returns
    -------
    dict
        ``{"masks": {name: source}, "masks_missing": {name: reason}}``: the scene's masks in
        the order of :data:`MASK_ORDER` (a file such as ``"nonocc.png"``, or how the mask
        was derived), and each mask of :data:`MASK_ORDER` it does not have, with the reason
        (``"no disc.png in the folder"``).

    Examples
    --------
    >>> import numpy as np
    >>> known = np.ones((2, 3), dtype=bool)
    >>> scene = StereoScene("toy", known * 0, known * 0, np.zeros((2, 3), np.float32),
    ...                     {"nonocc": known}, max_disparity=2,
    ...                     meta={"missing_masks": {"all": "no all.png in the folder"}})
    >>> scene_masks(scene)["masks_missing"]
    {'all': 'no all.png in the folder', 'disc': 'not in the scene'}
    """
    sources = scene.meta.get(MASK_SOURCES, {})
    reasons = scene.meta.get(MISSING_MASKS, {})
    names = [m for m in MASK_ORDER if m in scene.masks]
    names += [m for m in scene.masks if m not in names]
    return {
        "masks": {name: sources.get(name, name) for name in names},
        "masks_missing": {
            name: reasons.get(name, "not in the scene")
            for name in MASK_ORDER
            if name not in scene.masks
        },
    }


def evaluate_file(
    prediction: str | os.PathLike,
    scene_dir: str | os.PathLike,
    *,
    scale: float | None = None,
    truth_scale: float | None = None,
    frame: str | int | None = None,
) -> dict:
    """Score a disparity file (PFM, or 16-bit PNG of ``d * 256``) against a scene folder.

    Parameters
    ----------
    prediction : path-like
        The disparity map of the scene's left view.
    scene_dir : path-like
        A scene folder of any layout (:func:`dcstereo.evaluation.datasets.load_scene`).
    scale : float, optional
        Stored value per pixel of disparity of the prediction
        (:func:`dcstereo.io.read_disparity`): required for an 8-bit image, 256 for a
        16-bit one by default.
    truth_scale : float, optional
        The ``scale`` of :func:`~dcstereo.evaluation.datasets.load_scene`: the ground truth's stored
        gray value per pixel of disparity, for a 2005/2006 scene of no standard size
        (other layouts refuse it: their files give the scale).
    frame : str or int, optional
        The frame of a KITTI training folder (``"000046_10"``).

    Returns
    -------
    dict
        ``{"prediction", "scene", "layout", "size", "scores", "masks", "masks_missing"}``
        with ``scores`` as in :func:`score` (one entry per mask the scene has) and the last
        two as in :func:`scene_masks`.
    """
    from dcstereo.io import read_disparity

    scene = load_scene(scene_dir, scale=truth_scale, frame=frame)
    disparity = read_disparity(prediction, scale=scale)
    return {
        "prediction": str(prediction),
        "scene": scene.name,
        "layout": scene.meta.get("layout", ""),
        "size": [scene.shape[1], scene.shape[0]],
        "scores": score(disparity, scene),
        **scene_masks(scene),
    }


def mask_lines(result: dict) -> list[str]:
    """Say, for :func:`evaluate_file`'s result, the masks scored and those not (or nothing).

    Empty when the scene has every mask of :data:`MASK_ORDER`; otherwise two lines,
    ``scored on: nonocc (nonocc.png)`` and ``not scored: all (no all.png in the folder),
    disc (...)``.
    """
    if not result["masks_missing"]:
        return []
    used = ", ".join(f"{name} ({source})" for name, source in result["masks"].items())
    missing = ", ".join(f"{name} ({why})" for name, why in result["masks_missing"].items())
    return [f"scored on: {used}", f"not scored: {missing}"]


def run_scene(method: str, scene: StereoScene, **options) -> DisparityResult:
    """Run :func:`run_method` on ``scene``'s pair over the scene's disparity range."""
    return run_method(
        method,
        scene.left,
        scene.right,
        max_disparity=scene.max_disparity,
        min_disparity=scene.min_disparity,
        **options,
    )


#: The rows of a scene a method is first run on, untimed, by :func:`bench`: as many as the
#: coarse views of ``sgm``'s photometric and row alignment stages need (64).
WARM_UP_ROWS = photometric.COARSE_FACTOR * photometric.MIN_COARSE_SIDE


def _warm_up(method: str, scene: StereoScene, options: dict, done: set) -> None:
    """Run once on a band of rows so that compiling is not timed (numba caches per process).

    :data:`WARM_UP_ROWS` rows: enough for the coarse pass of ``sgm``'s stages, whose
    kernels would otherwise compile in the first timed call.
    """
    if method in done or method in OPENCV_METHODS:
        return
    rows = min(scene.shape[0], WARM_UP_ROWS)
    run_method(
        method,
        scene.left[:rows],
        scene.right[:rows],
        max_disparity=scene.max_disparity,
        min_disparity=scene.min_disparity,
        **options,
    )
    done.add(method)


def bench(
    scenes: Iterable[StereoScene | str | os.PathLike | tuple[Path, str]],
    methods: Sequence[str],
    *,
    options: dict | None = None,
    match_options: dict | None = None,
    thresholds: Sequence[float] = DEFAULT_THRESHOLDS,
    progress=None,
    keep_results: bool = False,
    truth_scale: float | None = None,
) -> list[dict]:
    """Run every method on every scene and score it, sparse and dense.

    Parameters
    ----------
    scenes : iterable of StereoScene or path-like
        Scenes, or scene folders (loaded with :func:`load_scene`), or ``(KITTI training
        folder, frame)`` pairs.
    methods : sequence of str
        Names from :func:`available_methods`.
    options : dict, optional
        Passed to every method (for example ``{"window": 5}``).
    match_options : dict, optional
        Passed to dcstereo's methods only, not to OpenCV's: the options of
        :func:`dcstereo.match` that OpenCV's matchers do not have (for example
        ``{"subpixel": "equiangular", "occlusion_cost": 12}``). Each method's own
        parameters (:data:`dcstereo.params.METHOD_OPTIONS`) go to the methods that read
        them; one that none of ``methods`` reads is refused (``ValueError``).
    thresholds : sequence of float
        Bad-pixel thresholds.
    progress : callable, optional
        Called with ``(scene_name, method, seconds)`` after each run.
    keep_results : bool
        Keep the :class:`DisparityResult` of each run under ``"result"``.
    truth_scale : float, optional
        The ground truth's stored gray value per pixel of disparity for the 2005/2006
        scene folders (those of no standard size need it); the other layouts' files give
        their own, and scenes passed as :class:`StereoScene` are already loaded.

    Returns
    -------
    list of dict
        One row per (scene, method): ``{"scene", "method", "size", "max_disparity",
        "seconds", "features", "sparse": scores, "dense": scores, "masks",
        "masks_missing"}`` with scores as in :func:`score` (the masks the scene has) and
        the masks as in :func:`scene_masks`. ``seconds`` is the wall time of one call,
        compilation excluded; ``features`` the number of feature pairs (``dc``,
        ``dc-linear``) or control points (``dsi3-gcp``), None for the methods without.
    """
    options = dict(options or {})
    ours = {**options, **(match_options or {})}
    check_method_options(ours, methods)
    warmed: set = set()
    rows = []
    for item in scenes:
        scene = item if isinstance(item, StereoScene) else _load(item, truth_scale)
        for method in methods:
            method_options = options if method in OPENCV_METHODS else options_for(method, ours)
            _warm_up(method, scene, method_options, warmed)
            start = time.perf_counter()
            result = run_scene(method, scene, **method_options)
            seconds = time.perf_counter() - start
            row = {
                "scene": scene.name,
                "method": method,
                "size": [scene.shape[1], scene.shape[0]],
                "max_disparity": scene.max_disparity,
                "seconds": seconds,
                "features": None if result.features is None else len(result.features),
                "sparse": score(result.disparity, scene, thresholds),
                "dense": score(result.filled().disparity, scene, thresholds),
                **scene_masks(scene),
            }
            if keep_results:
                row["result"] = result
            rows.append(row)
            if progress is not None:
                progress(scene.name, method, seconds)
    return rows


def _load(folder, truth_scale: float | None) -> StereoScene:
    """:func:`load_scene`, with ``truth_scale`` for a 2005/2006 folder only.

    ``folder`` may be ``(KITTI training folder, frame)``.
    """
    if isinstance(folder, tuple):
        return load_scene(folder[0], frame=folder[1])
    is_2005 = scene_layout(folder) == "2005/2006"
    return load_scene(folder, scale=truth_scale if is_2005 else None)


def bench_folder(data_dir: str | os.PathLike, methods: Sequence[str], **kwargs) -> list[dict]:
    """:func:`bench` over every scene folder under ``data_dir`` (:func:`find_scenes`).

    :func:`find_scenes` knows a scene by its file names only, so every scene is loaded
    once before any method runs (and again, one at a time, by :func:`bench`): a broken
    one fails the bench up front rather than after the scenes before it.

    Raises
    ------
    ValueError
        When there is no scene under ``data_dir``, or a scene cannot be loaded (the
        message lists every such scene).
    """
    from dcstereo.evaluation.kitti import expand_frames

    folders = expand_frames(find_scenes(data_dir))  # a KITTI folder: each of its frames
    if not folders:
        raise ValueError(f"no scene folder (of any known layout) under {data_dir}")
    problems = []
    for folder in folders:
        try:
            _load(folder, kwargs.get("truth_scale"))
        except (ValueError, OSError) as err:
            text = str(err).strip()
            problems.append(text.splitlines()[0] if text else f"{folder}: {type(err).__name__}")
    if problems:
        raise ValueError(
            f"{len(problems)} of {len(folders)} scene folders under {data_dir} cannot be "
            f"benched: {'; '.join(problems)}"
        )
    return bench(folders, methods, **kwargs)


def mean_rows(rows: Sequence[dict]) -> list[dict]:
    """Average every number over the scenes, per method (masks missing in a scene skipped).

    Parameters
    ----------
    rows : sequence of dict
        Rows of :func:`bench`.

    Returns
    -------
    list of dict
        One row per method, in first-seen order, shaped like the rows of :func:`bench`
        with ``scene`` = ``"mean"`` and ``"scenes"`` the number of scenes averaged.
    """
    methods = list(dict.fromkeys(row["method"] for row in rows))
    means = []
    for method in methods:
        mine = [row for row in rows if row["method"] == method]
        mean = {"scene": "mean", "method": method, "scenes": len(mine)}
        mean["seconds"] = float(np.mean([row["seconds"] for row in mine]))
        for kind in ("sparse", "dense"):
            mean[kind] = {}
            masks = dict.fromkeys(m for row in mine for m in row[kind])
            for mask in masks:
                values = [row[kind][mask] for row in mine if mask in row[kind]]
                mean[kind][mask] = {
                    key: float(np.mean([v[key] for v in values])) for key in values[0]
                }
        means.append(mean)
    return means


def missing_mask_lines(rows: Sequence[dict]) -> list[str]:
    """Say which scenes of :func:`bench`'s rows lack a mask of :data:`MASK_ORDER`, and why.

    One line per mask that some scene lacks (empty when every scene has every mask):
    ``disc: not scored on 2 of 5 scenes (no disc.png in the folder: a, b); its mean is
    over the other 3``. The table shows ``-`` in those cells, and the mean rows average
    each mask over the scenes that have it.
    """
    scenes: dict[str, dict] = {}
    for row in rows:
        scenes.setdefault(row["scene"], row.get("masks_missing", {}))
    lines = []
    for mask in MASK_ORDER:
        lacking = {name: why[mask] for name, why in scenes.items() if mask in why}
        if not lacking:
            continue
        by_reason: dict[str, list[str]] = {}
        for name, why in lacking.items():
            by_reason.setdefault(why, []).append(name)
        reasons = "; ".join(f"{why}: {', '.join(names)}" for why, names in by_reason.items())
        rest = len(scenes) - len(lacking)
        mean = f"its mean is over the other {rest}" if rest else "it has no mean"
        lines.append(
            f"{mask}: not scored on {len(lacking)} of {len(scenes)} scenes ({reasons}); {mean}"
        )
    return lines


def _cell(scores: dict, mask: str, key: str, digits: int = 2) -> str:
    value = scores.get(mask, {}).get(key)
    if value is None:
        return "-"
    return "nan" if value != value else f"{value:.{digits}f}"


def bench_table(rows: Sequence[dict], *, title: str | None = None, threshold: float = 1.0):
    """Build a rich table of :func:`bench` rows, then the mean row of each method.

    Columns: scene, method, the dense map's bad-``threshold`` in the nonocc / all / disc
    masks (%) and its mean absolute error over nonocc (px), the sparse map's density over
    ``all`` (%), and the time (ms).

    Parameters
    ----------
    rows : sequence of dict
        Rows of :func:`bench`.
    title : str, optional
        The table's title.
    threshold : float
        The bad-pixel threshold shown; the rows must have been scored with it.

    Returns
    -------
    rich.table.Table

    Raises
    ------
    ValueError
        When the rows have no bad-``threshold`` score.
    """
    from rich.table import Table

    key = bad_key(threshold)
    if rows and not any(key in scores for scores in rows[0]["dense"].values()):
        raise ValueError(f"the rows were not scored at the threshold {threshold:g} ({key})")
    table = Table(title=title)
    for name, justify in [
        ("scene", "left"),
        ("method", "left"),
        (f"{key} nonocc %", "right"),
        (f"{key} all %", "right"),
        (f"{key} disc %", "right"),
        ("mae nonocc px", "right"),
        ("density %", "right"),
        ("time ms", "right"),
    ]:
        table.add_column(name, justify=justify)  # type: ignore[arg-type]
    means = mean_rows(rows)
    for index, row in enumerate(list(rows) + means):
        if index == len(rows):
            table.add_section()
        table.add_row(
            row["scene"],
            row["method"],
            _cell(row["dense"], "nonocc", key),
            _cell(row["dense"], "all", key),
            _cell(row["dense"], "disc", key),
            _cell(row["dense"], "nonocc", "mae", 3),
            _cell(row["sparse"], "all", "density", 1),
            f"{1000 * row['seconds']:.0f}",
        )
    return table


def scores_table(result: dict):
    """Build a rich table of :func:`evaluate_file`: one row per mask, one column per metric."""
    from rich.table import Table

    scores = result["scores"]
    keys = list(next(iter(scores.values())))
    table = Table(title=f"{result['prediction']} against {result['scene']}")
    table.add_column("mask")
    for key in keys:
        unit = "px" if key in ("mae", "rms") else "%"
        table.add_column(f"{key} {unit}", justify="right")
    for mask in scores:
        table.add_row(mask, *[_cell(scores, mask, key) for key in keys])
    return table


def render(table, width: int = 120) -> str:
    """Render a rich table as plain text (no colour codes), for printing or files."""
    from rich.console import Console

    buffer = io.StringIO()
    console = Console(file=buffer, width=width, color_system=None, force_terminal=False)
    console.print(table)
    return buffer.getvalue()


def json_rows(rows: Sequence[dict]) -> list[dict]:
    """Rows of :func:`bench` without the results, ready for :func:`to_json`."""
    return [{k: v for k, v in row.items() if k != "result"} for row in rows]


def _finite_or_none(value):
    if isinstance(value, dict):
        return {key: _finite_or_none(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [_finite_or_none(item) for item in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def to_json(payload, *, indent: int | None = 1) -> str:
    """Strict JSON text of scores: every NaN or infinite float becomes ``null``.

    A score over no estimate is NaN (``mae`` and ``rms`` of an empty map), which
    :func:`json.dumps` would write as ``NaN``, a token JSON does not have;
    ``allow_nan=False`` makes any value this misses an error instead.

    Parameters
    ----------
    payload : dict or list
        Plain Python values (nested dicts, lists, str, int, float, bool, None).
    indent : int, optional
        As for :func:`json.dumps`.

    Returns
    -------
    str
    """
    return json.dumps(_finite_or_none(payload), indent=indent, allow_nan=False)


def machine_description() -> dict:
    """Describe what the timings ran on: CPU, cores, numba threads, Python and library versions."""
    import numba

    cpu = platform.processor() or platform.machine()
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.is_file():
        for line in cpuinfo.read_text(errors="replace").splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    info = {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "numba_threads": numba.get_num_threads(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "numba": numba.__version__,
        "system": platform.platform(),
    }
    if opencv_available():
        import cv2

        info["opencv"] = cv2.__version__
        info["opencv_threads"] = cv2.getNumThreads()
    return info
