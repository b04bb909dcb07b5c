"""Match many stereo pairs, here or on a Dask cluster, and lose nothing.

* Every output is written atomically (a temporary name in the same folder, then a
  rename); a rerun *resumes*: pairs whose disparity file exists and is complete (its
  header parses and its size is what the header says, see :func:`dcstereo.io.is_complete`)
  are skipped, the rest, a file damaged after it was written included, are redone.
* A pair that fails (unreadable image, sizes that differ, a bad range for its size) is
  recorded with its reason, the others go on, and ``failures.csv`` lists them.
* With ``confidence=True`` each pair's confidence map (:mod:`dcstereo.refine.confidence`) is
  written too, ``confidence/<name>.pfm``, computed by the worker that matched the pair.
* With ``depth=True`` each pair's depth map is written too, ``depth/<name>.pfm``, from
  one calibration for all pairs or from the ``calib.txt`` in each pair folder (the
  Middlebury 2014 layout); a pair is complete when both of its files are.
* On Dask there is one task per pair; a task lost with its worker is run again
  elsewhere (``retries``), and numba uses one thread inside each task so the worker's
  cores are not oversubscribed. The library never starts a cluster: pass a
  ``distributed.Client`` (the CLI's ``--scheduler local:N`` is what starts one).

Workers read the input images themselves (they must see the same paths: one machine or
a shared file system) and send the disparity back; only this process writes outputs.
"""

import contextlib
import csv
import dataclasses
import json
import math
import os
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

from dcstereo import geometry, io
from dcstereo import params as _params
from dcstereo._checks import is_integer, is_number
from dcstereo.api import match
from dcstereo.geometry import Calibration
from dcstereo.params import MatchParams
from dcstereo.refine.confidence import confidence as confidence_map

#: Image names a pair folder may use, in the order they are tried.
PAIR_NAMES = (("left", "right"), ("im0", "im1"))
#: The file (in the output folder) listing the pairs that failed.
FAILURES_FILE = "failures.csv"
#: The file (in the output folder) recording the options the outputs were made with.
OPTIONS_FILE = "batch.json"
#: The folder (in the output folder) of the depth maps, ``<name>.pfm`` each.
DEPTH_FOLDER = "depth"
#: The folder (in the output folder) of the confidence maps, ``<name>.pfm`` each.
CONFIDENCE_FOLDER = "confidence"
#: The folder (in the output folder) of the point clouds, ``<name>.ply`` each.
CLOUD_FOLDER = "cloud"
#: The file formats of the depth maps: float32 PFM, or 16-bit PNG of ``round(z * scale)``.
DEPTH_FORMATS = ("pfm", "png")
#: A pair folder's calibration file (Middlebury 2014's name and format).
CALIB_NAME = "calib.txt"
#: What outputs were made with when their ``batch.json`` predates an option.
ASSUMED_OPTIONS = {
    "subpixel": None,
    "median": 0,
    # the options of sgm (folders made before it by methods that do not read them)
    "census_window": list(_params.DEFAULT_CENSUS_WINDOW),
    "ad_truncation": _params.DEFAULT_AD_TRUNCATION,
    "p1": _params.DEFAULT_P1,
    "p2": _params.DEFAULT_P2,
    "p2_gradient": _params.DEFAULT_P2_GRADIENT,
    "paths": _params.DEFAULT_PATHS,
    "lr_tolerance": _params.DEFAULT_LR_TOLERANCE,
    # sgm's stages on request, recorded since they were added (off before)
    "planes": False,
    "aggregation": None,
    "cross_limit": _params.DEFAULT_CROSS_LIMIT,
    "cross_tau": _params.DEFAULT_CROSS_TAU,
    "cross_iterations": _params.DEFAULT_CROSS_ITERATIONS,
    "census_step": _params.DEFAULT_CENSUS_STEP,
    "photometric": None,
    "census_smoothing": _params.DEFAULT_CENSUS_SMOOTHING,
    "row_alignment": None,
    "edges": None,
}
#: Longest pair name, in bytes of UTF-8: the temporary name of its output
#: (:data:`dcstereo.io.TEMPORARY_NAME_EXTRA` more than ``<name>.pfm``) must fit the 255
#: bytes file systems allow a name.
MAX_NAME_BYTES = 255 - io.TEMPORARY_NAME_EXTRA - len(".pfm")


@dataclasses.dataclass(frozen=True)
class Pair:
    """One stereo pair of a batch.

    Attributes
    ----------
    name : str
        Unique name; the disparity is written to ``<name>.pfm``.
    left, right : Path or None
        The images; None when the pair folder has no such image (the pair then fails
        with ``problem`` as its reason).
    problem : str or None
        Why the pair cannot be run, found while listing it.
    calib : Path or None
        The pair's calibration file (``calib.txt`` in its folder), for ``depth=True``.
    """

    name: str
    left: Path | None
    right: Path | None
    problem: str | None = None
    calib: Path | None = None


@dataclasses.dataclass(frozen=True)
class FailureRow:
    """One row of ``failures.csv``: what failed, from which inputs, and why."""

    name: str
    left: str
    right: str
    error: str


@dataclasses.dataclass
class PairOutcome:
    """What happened to one pair: ``status`` is ``"done"``, ``"skipped"`` or ``"failed"``."""

    pair: Pair
    status: str
    message: str = ""
    seconds: float = 0.0


@dataclasses.dataclass
class BatchReport:
    """Outcome of :func:`run_batch`, one :class:`PairOutcome` per pair, in pair order."""

    outcomes: list[PairOutcome] = dataclasses.field(default_factory=list)
    seconds: float = 0.0

    def _names(self, status):
        return [o.pair.name for o in self.outcomes if o.status == status]

    @property
    def done(self) -> list[str]:
        """Names of the pairs matched in this run."""
        return self._names("done")

    @property
    def skipped(self) -> list[str]:
        """Names of the pairs whose output was already complete."""
        return self._names("skipped")

    @property
    def failed(self) -> list[PairOutcome]:
        """The pairs that failed, with their reasons."""
        return [o for o in self.outcomes if o.status == "failed"]

    @property
    def ok(self) -> bool:
        """True when no pair failed."""
        return not self.failed


def find_pairs(source: str | os.PathLike) -> list[Pair]:
    """List the pairs of a batch given as a CSV file or a folder of pair folders.

    Parameters
    ----------
    source : str or os.PathLike
        A ``.csv`` file whose rows are ``left,right[,name]`` (an optional header row
        ``left,right,name``; relative paths are relative to the CSV's folder; the name
        defaults to the left image's stem, or ``<folder>-<stem>`` when stems repeat, or
        the folder's name when the stem is ``left`` or ``im0``), or
        a folder holding one folder per pair, named after the pair, with ``left.*`` and
        ``right.*`` or Middlebury's ``im0.*`` and ``im1.*`` (and, if there is one, its
        ``calib.txt``: the pair's :attr:`Pair.calib`).

    Returns
    -------
    list of Pair
        In file order (CSV) or sorted by folder name. A pair folder without its two
        images is listed with a ``problem`` so that it is reported, not silently lost.

    Raises
    ------
    ValueError
        If the source does not exist, the CSV is malformed, names repeat, or the folder
        holds no pair folder.
    """
    path = Path(source)
    if path.is_dir():
        return _pairs_from_folder(path)
    if not path.exists():
        raise ValueError(f"cannot read pairs '{source}': no such file or folder")
    return _pairs_from_csv(path)


def _pairs_from_folder(folder: Path) -> list[Pair]:
    pairs = []
    for sub in sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith(".")):
        files = [f for f in sub.iterdir() if f.is_file() and not f.name.startswith(".")]
        found, problem = None, None
        for left_stem, right_stem in PAIR_NAMES:
            lefts = [f for f in files if f.stem.lower() == left_stem]
            rights = [f for f in files if f.stem.lower() == right_stem]
            if not lefts and not rights:
                continue
            if len(lefts) != 1 or len(rights) != 1:
                problem = (
                    f"folder '{sub}' needs exactly one {left_stem}.* and one {right_stem}.* "
                    f"(found {len(lefts)} and {len(rights)})"
                )
            else:
                found = (lefts[0], rights[0])
            break
        if found is None and problem is None:
            problem = f"folder '{sub}' holds neither left.*/right.* nor im0.*/im1.*"
        left, right = found if found else (None, None)
        calib = sub / CALIB_NAME
        pairs.append(Pair(sub.name, left, right, problem, calib if calib.is_file() else None))
    if not pairs:
        raise ValueError(f"folder '{folder}' holds no pair folders")
    return pairs


def _pairs_from_csv(path: Path) -> list[Pair]:
    try:
        # utf-8-sig: a byte order mark (spreadsheets write one) is not part of the first cell
        with open(path, newline="", encoding="utf-8-sig") as f:
            rows = [r for r in csv.reader(f) if r and any(cell.strip() for cell in r)]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise ValueError(f"cannot read pairs '{path}': {exc}") from None
    if rows and [c.strip().lower() for c in rows[0][:2]] == ["left", "right"]:
        rows = rows[1:]
    if not rows:
        raise ValueError(f"pairs file '{path}' lists no pairs")
    base = path.parent
    entries = []
    for number, row in enumerate(rows, start=1):
        cells = [c.strip() for c in row]
        if len(cells) not in (2, 3) or not cells[0] or not cells[1]:
            raise ValueError(
                f"pairs file '{path}', pair {number}: expected 'left,right[,name]', got {row}"
            )
        left, right = (base / cells[0], base / cells[1])
        entries.append((left, right, cells[2] if len(cells) == 3 and cells[2] else None))
    generic = {left_stem for left_stem, _ in PAIR_NAMES}
    stems = [left.stem for left, _, name in entries if name is None]
    repeated = {s for s in stems if stems.count(s) > 1}
    pairs = []
    for left, right, name in entries:
        if name is None and left.stem.lower() in generic:
            name = left.parent.name  # .../scene/im0.png is the pair "scene"
        elif name is None:
            name = f"{left.parent.name}-{left.stem}" if left.stem in repeated else left.stem
        pairs.append(Pair(name, left, right))
    _check_names(pairs, str(path))
    return pairs


def _check_names(pairs: Sequence[Pair], where: str) -> None:
    seen = set()
    for pair in pairs:
        if not isinstance(pair, Pair):
            raise TypeError(f"{where}: pairs must be Pair objects, got {type(pair).__name__}")
        if not isinstance(pair.name, str):
            raise TypeError(f"{where}: a pair name must be a string, got {pair.name!r}")
        if not pair.name or pair.name in (".", "..") or any(c in pair.name for c in "/\\\0"):
            raise ValueError(f"{where}: {pair.name!r} cannot be a file name")
        if len(pair.name.encode("utf-8", "surrogateescape")) > MAX_NAME_BYTES:
            raise ValueError(
                f"{where}: the pair name '{pair.name[:20]}...' is longer than "
                f"{MAX_NAME_BYTES} bytes, too long for its output's file name"
            )
        if pair.name in seen:
            raise ValueError(f"{where}: the pair name '{pair.name}' is used twice")
        seen.add(pair.name)


def output_path(output_dir: str | os.PathLike, pair: Pair) -> Path:
    """Return where :func:`run_batch` writes the disparity of ``pair`` (``<name>.pfm``)."""
    return Path(output_dir) / f"{pair.name}.pfm"


def depth_path(output_dir: str | os.PathLike, pair: Pair, depth_format: str = "pfm") -> Path:
    """Return where :func:`run_batch` writes the depth of ``pair``: ``depth/<name>.pfm|png``."""
    return Path(output_dir) / DEPTH_FOLDER / f"{pair.name}.{depth_format}"


def confidence_path(output_dir: str | os.PathLike, pair: Pair) -> Path:
    """Return where :func:`run_batch` writes the confidence of ``pair``."""
    return Path(output_dir) / CONFIDENCE_FOLDER / f"{pair.name}.pfm"


def cloud_path(output_dir: str | os.PathLike, pair: Pair) -> Path:
    """Return where :func:`run_batch` writes the point cloud of ``pair`` (``cloud/<name>.ply``)."""
    return Path(output_dir) / CLOUD_FOLDER / f"{pair.name}.ply"


def run_batch(
    pairs: Iterable[Pair],
    output_dir: str | os.PathLike,
    *,
    max_disparity: int,
    client=None,
    resume: bool = True,
    retries: int = 2,
    threads: int | None = None,
    on_outcome: Callable[[PairOutcome], None] | None = None,
    depth: bool = False,
    calibration: Calibration | None = None,
    confidence: bool = False,
    ply: bool = False,
    depth_format: str = "pfm",
    depth_scale: float | None = None,
    **options,
) -> BatchReport:
    """Match every pair and write ``<name>.pfm`` into ``output_dir``, atomically.

    Parameters
    ----------
    pairs : iterable of Pair
        From :func:`find_pairs`, or built by hand.
    output_dir : str or os.PathLike
        Folder for the outputs, ``failures.csv`` (``name,left,right,error``, a header
        only when nothing failed) and ``batch.json`` (the options); created, with its
        parents, once the pairs and options are found valid.
    max_disparity : int
        Largest disparity searched.
    client : distributed.Client, optional
        Run one task per pair on this client. None: run here, one pair after the other,
        each with all of numba's threads.
    resume : bool
        Skip the pairs whose output exists and is complete (:func:`dcstereo.io.is_complete`;
        an incomplete one is redone and counted as done). The options must then be
        those recorded in ``batch.json`` by the earlier run; ``resume=False``
        recomputes everything.
    retries : int
        Dask only: times a task is run again when it raises unexpectedly (a lost
        worker is handled by the scheduler on top of this).
    threads : int, optional
        numba threads per pair; default all cores here, 1 inside a Dask task. numba's
        count is restored after each pair.
    on_outcome : callable, optional
        Called with each :class:`PairOutcome` as it is known (for progress bars).
    depth : bool
        Also write each pair's depth map (:func:`dcstereo.geometry.depth`, PFM, in the
        baseline's unit, ``inf`` = none) to ``depth/<name>.pfm``. A pair is then complete
        (skipped on resume) only when both files are, and a pair without a calibration
        fails, reported with the others.
    calibration : Calibration, optional
        With ``depth`` or ``ply``: the geometry of every pair. None: each pair's own
        ``calib.txt`` (:attr:`Pair.calib`, read by :meth:`Calibration.from_middlebury`).
    confidence : bool
        Also write each pair's confidence map (:func:`dcstereo.refine.confidence.confidence`,
        PFM, ``inf`` = none) to ``confidence/<name>.pfm``; a pair is then complete only
        with it.
    depth_format : {"pfm", "png"}
        With ``depth``: ``depth/<name>.pfm`` (float32) or ``depth/<name>.png`` (16 bits of
        ``round(z * depth_scale)``, 0 = none, the RGB-D convention; a depth beyond 16 bits
        is written as none, see :func:`dcstereo.io.write_depth_png16`).
    depth_scale : float, optional
        With ``depth_format="png"``: stored value per unit of depth (default 1:
        millimetres for a baseline in millimetres).
    ply : bool
        Also write each pair's point cloud (:func:`dcstereo.geometry.point_cloud` of its
        disparity, coloured by its left image when that is 8 or 16 bits; binary PLY) to
        ``cloud/<name>.ply``; it needs a calibration as ``depth`` does, and a pair is
        then complete only with it. The left image is read again where the outputs are
        written, for the colours.
    **options
        The other options of :func:`dcstereo.match` (``min_disparity``, ``method``,
        ``window``...).

    Returns
    -------
    BatchReport
        Failures are reported there and in ``failures.csv``, never raised.

    Raises
    ------
    ValueError
        For options :func:`dcstereo.match` refuses, a ``threads`` or ``retries`` out of
        range, pair names that repeat or cannot be file names, an output folder that is a
        file or cannot be created, or, when resuming, outputs made with other options or
        an unreadable ``batch.json`` (before any pair runs; bad options leave no folder).
    TypeError
        For pairs that are not :class:`Pair` objects, or options of the wrong type.
    """
    start = time.perf_counter()
    pairs = list(pairs)
    folder = Path(output_dir)
    _check_names(pairs, "batch")
    check_threads(threads, client)
    if not is_integer(retries) or retries < 0:
        raise ValueError(f"retries must be an integer 0 or more, got {retries!r}")
    params = MatchParams(max_disparity=max_disparity, **options)  # refuse bad options now
    match_kwargs = {"max_disparity": max_disparity, **options}
    companions = companion_options(
        depth, calibration, confidence, ply, depth_format=depth_format, depth_scale=depth_scale
    )
    if calibration is not None and not (depth or ply):
        raise ValueError("calibration is used only with depth=True or ply=True")
    recorded = {**dataclasses.asdict(params), **companions}
    make_output_folder(folder)
    check_recorded_options(folder, recorded, resume, assumed=ASSUMED_OPTIONS)
    extras = {DEPTH_FOLDER: depth, CONFIDENCE_FOLDER: confidence, CLOUD_FOLDER: ply}
    for name in (name for name, wanted in extras.items() if wanted):
        make_output_folder(folder / name)
    report = BatchReport()
    by_name: dict[str, PairOutcome] = {}

    def record(outcome):
        by_name[outcome.pair.name] = outcome
        if on_outcome is not None:
            on_outcome(outcome)

    todo = []
    cameras = {}
    outputs_of = {
        p.name: _outputs(folder, p, depth and depth_format, confidence, ply) for p in pairs
    }
    # what a killed run left half-written (never a real output), each folder listed once
    io.remove_stale_temporaries(*(path for paths in outputs_of.values() for path in paths))
    for pair in pairs:
        outputs = outputs_of[pair.name]
        problem = pair.problem
        if problem is None and (depth or ply):
            cameras[pair.name], problem = _camera(pair, calibration, depth, ply)
        if problem is not None:
            record(PairOutcome(pair, "failed", problem))
        elif resume and all(io.is_complete(path) for path in outputs):
            record(PairOutcome(pair, "skipped"))
        else:
            todo.append(pair)

    def finish(pair, answer):
        depth_to = depth_path(folder, pair, depth_format) if depth else None
        record(_finish(folder, pair, answer, cameras.get(pair.name), depth_to, depth_scale, ply))

    if client is None:
        for pair in todo:
            finish(pair, match_pair(pair, match_kwargs, threads, confidence))
    else:
        _run_on_dask(client, todo, match_kwargs, retries, threads, confidence, finish)
    report.outcomes = [by_name[p.name] for p in pairs]
    write_failures(
        folder,
        [
            FailureRow(o.pair.name, str(o.pair.left or ""), str(o.pair.right or ""), o.message)
            for o in report.failed
        ],
    )
    report.seconds = time.perf_counter() - start
    return report


def match_pair(
    pair: Pair, match_kwargs: dict, threads: int | None = None, confidence: bool = False
):
    """Read and match one pair; return ``(disparity, seconds, sure)`` or ``(None, reason, None)``.

    ``sure`` is the confidence map when ``confidence``, else None. The reasons a pair can
    fail on its own (unreadable image, sizes that differ, a range or window that does not
    fit) come back as a one-line message; anything else raises (and, on Dask, makes the
    task retry).
    """
    if pair.left is None or pair.right is None:
        side = "left" if pair.left is None else "right"
        return None, f"pair '{pair.name}' has no {side} image", None
    with numba_threads(threads):
        start = time.perf_counter()
        try:
            left = io.read_image(pair.left)
            right = io.read_image(pair.right)
            result = match(left, right, **match_kwargs)
        except (ValueError, TypeError) as exc:
            reason = str(exc).strip().splitlines()[0] if str(exc).strip() else repr(exc)
            return None, reason, None
        sure = confidence_map(result, left, right) if confidence else None
        return result.disparity, time.perf_counter() - start, sure


def check_threads(threads, client=None) -> None:
    """Refuse a ``threads`` argument that is not None or a count numba can use.

    Without a Dask ``client`` the count must also be at most numba's threads here (on a
    cluster each worker has its own).
    """
    if threads is None:
        return
    if not is_integer(threads):
        raise TypeError(f"threads must be an integer, got {threads!r}")
    if threads < 1:
        raise ValueError(f"threads must be at least 1, got {threads}")
    if client is None:
        import numba

        most = numba.config.NUMBA_NUM_THREADS
        if threads > most:
            raise ValueError(f"threads must be between 1 and {most}, got {threads}")


@contextlib.contextmanager
def numba_threads(threads: int | None):
    """Set numba's thread count to ``threads`` for the body, then restore it (None: keep it)."""
    if threads is None:
        yield
        return
    import numba

    previous = numba.get_num_threads()
    numba.set_num_threads(int(threads))
    try:
        yield
    finally:
        numba.set_num_threads(previous)


def _outputs(folder: Path, pair: Pair, depth, confidence: bool, ply: bool) -> list[Path]:
    """Return the files :func:`run_batch` writes for ``pair`` (``depth``: format or False)."""
    paths = [output_path(folder, pair)]
    paths += [depth_path(folder, pair, depth)] if depth else []
    paths += [confidence_path(folder, pair)] if confidence else []
    paths += [cloud_path(folder, pair)] if ply else []
    return paths


def _camera(pair: Pair, calibration: Calibration | None, depth: bool, ply: bool):
    """Return ``(Calibration, None)`` for ``pair``'s depth or cloud, or ``(None, reason)``."""
    if calibration is not None:
        return calibration, None
    if pair.calib is None:
        what = " and ".join(name for name, on in (("depth", depth), ("point cloud", ply)) if on)
        return None, (
            f"pair '{pair.name}' has no {CALIB_NAME} for its {what} (give one calibration "
            "for all pairs: calibration=, or batch --calib)"
        )
    try:
        return Calibration.from_middlebury(pair.calib), None
    except (ValueError, TypeError) as exc:
        return None, str(exc).strip().splitlines()[0]


def companion_options(
    depth: bool,
    calibration: Calibration | None,
    confidence: bool,
    ply: bool = False,
    *,
    depth_format: str = "pfm",
    depth_scale: float | None = None,
) -> dict:
    """Check the options of the maps written beside each disparity; return their record.

    The record is what ``batch.json`` keeps of them (:func:`run_batch` and
    :func:`dcstereo.batch.video.match_sequence`): only the maps switched on, so that a
    ``batch.json`` from before them still resumes.
    """
    if calibration is not None and not isinstance(calibration, Calibration):
        raise TypeError(
            f"calibration must be a Calibration or None, got {type(calibration).__name__}"
        )
    for name, flag in (("depth", depth), ("confidence", confidence), ("ply", ply)):
        if not isinstance(flag, bool):
            raise TypeError(f"{name} must be a bool, got {flag!r}")
    if depth_format not in DEPTH_FORMATS:
        raise ValueError(f"depth_format must be 'pfm' or 'png', got {depth_format!r}")
    if depth_format != "pfm" and not depth:
        raise ValueError("depth_format is used only when the depth maps are written")
    if depth_scale is not None:
        if depth_format != "png":
            raise ValueError("depth_scale is used only with depth_format='png'")
        if not is_number(depth_scale) or not (0 < depth_scale < math.inf):
            raise ValueError(f"depth_scale must be a positive number, got {depth_scale!r}")
    recorded = {}
    camera = dataclasses.asdict(calibration) if calibration is not None else None
    if depth:
        recorded["depth"] = camera or f"each pair's {CALIB_NAME}"
    if depth and depth_format == "png":  # only then: a batch.json from before still resumes
        recorded["depth_png_scale"] = 1.0 if depth_scale is None else float(depth_scale)
    if confidence:
        recorded["confidence"] = True
    if ply:
        recorded["ply"] = camera or f"each pair's {CALIB_NAME}"
    return recorded


def write_companions(
    disparity, camera: Calibration | None, depth_to, sure, confidence_to, cloud=None,
    depth_scale=None,
):  # fmt: skip
    """Write a disparity map's depth, confidence and point cloud, those that are asked for.

    The depth given ``camera`` and ``depth_to``, the confidence given ``sure``, the cloud
    given ``cloud``, its path and its colours (or None; it needs ``camera`` too). The
    depth's format is its path's suffix (``depth_scale``: a PNG's value per unit). Before
    the disparity itself: its file is what says the pair or frame is done.
    """
    if camera is not None and depth_to is not None:  # a scale only for a PNG (checked)
        io.write_depth(depth_to, geometry.depth(disparity, camera), scale=depth_scale)
    if sure is not None:
        io.write_pfm(confidence_to, sure)
    if cloud is not None:
        cloud_to, colors = cloud
        points = geometry.point_cloud(disparity, camera, colors)
        io.write_ply(cloud_to, points.points, points.colors)


def _cloud_colors(pair: Pair):
    """Return the left image of ``pair`` for a cloud's colours (None unless 8 or 16 bits)."""
    image = io.read_image(pair.left)
    return image if image.dtype.kind == "u" else None


def _finish(
    folder: Path, pair: Pair, answer, camera: Calibration | None, depth_to, depth_scale, ply
) -> PairOutcome:
    disparity, detail, sure = answer
    if disparity is None:
        return PairOutcome(pair, "failed", detail)
    try:
        cloud = (cloud_path(folder, pair), _cloud_colors(pair)) if ply else None
    except (ValueError, TypeError) as exc:  # the left image went away since it was matched
        return PairOutcome(pair, "failed", str(exc).strip().splitlines()[0])
    write_companions(
        disparity, camera, depth_to, sure, confidence_path(folder, pair), cloud, depth_scale
    )
    io.write_disparity(output_path(folder, pair), disparity)
    return PairOutcome(pair, "done", seconds=detail)


def _run_on_dask(client, pairs, match_kwargs, retries, threads, confidence, finish):
    from distributed import as_completed

    futures = {}
    for pair in pairs:
        future = client.submit(
            match_pair,
            pair,
            match_kwargs,
            1 if threads is None else threads,
            confidence,
            key=f"dcstereo-pair-{pair.name}-{os.urandom(4).hex()}",
            retries=retries,
        )
        futures[future.key] = (future, pair)
    for future in as_completed([f for f, _ in futures.values()]):
        _, pair = futures.pop(future.key)
        try:
            answer = future.result()
        except Exception as exc:  # the task failed for good (KilledWorker, ...)
            answer = (None, f"task failed on the cluster: {type(exc).__name__}: {exc}", None)
        finish(pair, answer)
        future.release()


def make_output_folder(folder: Path) -> None:
    """Create the output folder and its parents; refuse a path that is not a folder."""
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"cannot write into '{folder}': it is not a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"cannot create output folder '{folder}': {exc.strerror or exc}") from None


def check_recorded_options(
    folder: Path, params: dict, resume: bool, assumed: dict | None = None
) -> None:
    """Refuse to resume over outputs made with other options; record the options.

    ``params`` (``dataclasses.asdict`` of :class:`~dcstereo.params.MatchParams`, plus
    any other option that changes what is written) is compared with ``batch.json`` in
    ``folder`` when resuming, and written there otherwise (or when there is none yet).
    ``assumed`` gives the value of options that an older ``batch.json`` does not record
    (what those outputs were made with, the default of the time).
    """
    recorded = folder / OPTIONS_FILE
    current = json.loads(json.dumps(params, sort_keys=True))
    if resume and recorded.is_file():
        try:
            previous = json.loads(recorded.read_text(encoding="utf-8"))
            if not isinstance(previous, dict):
                raise ValueError("not a JSON object")
        except (OSError, ValueError) as exc:
            reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
            raise ValueError(
                f"cannot read {recorded}: {reason}; remove it or use --no-resume (resume=False)"
            ) from None
        previous = {**(assumed or {}), **previous}
        differ = [
            f"{key} {previous.get(key, 'not recorded')} (now {current.get(key, 'not set')})"
            for key in sorted(previous.keys() | current.keys())
            if previous.get(key) != current.get(key)
        ]
        if differ:
            raise ValueError(
                f"'{folder}' holds outputs made with other options: {', '.join(differ)}; "
                "use --no-resume (resume=False) to recompute, or another folder"
            )
        return
    with io.atomic_write(recorded) as tmp:
        tmp.write_text(json.dumps(current, sort_keys=True, indent=1) + "\n", encoding="utf-8")


def write_failures(folder: Path, rows: list[FailureRow]) -> None:
    """Write ``failures.csv`` (``name,left,right,error``; a header alone when none failed)."""
    with io.atomic_write(folder / FAILURES_FILE) as tmp:
        with open(tmp, "w", newline="", encoding="utf-8") as f:
            writer = csv.writer(f)
            writer.writerow(["name", "left", "right", "error"])
            for row in rows:
                writer.writerow([row.name, row.left, row.right, row.error])


def read_failures(output_dir: str | os.PathLike) -> list[dict[str, str]]:
    """Read ``failures.csv`` of a batch output folder as a list of row dictionaries."""
    with open(Path(output_dir) / FAILURES_FILE, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))
