"""Stereo sequences: frame folders or videos in, one disparity and preview per frame out.

A sequence is two folders of frames (paired in name order), two videos (left and right)
or one side-by-side video (left half, right half). :func:`match_sequence` writes, for
frame ``i``, ``frame{i:05d}.pfm`` (or ``.png``, 16-bit) and ``frame{i:05d}-preview.png``,
each atomically, resumes like :func:`dcstereo.batch.run_batch` (frames whose two files
exist and are complete are skipped), reports frames that fail in ``failures.csv`` and
goes on, and can run one Dask task per frame. :func:`write_video` turns the previews into
a video.

Videos are read and written with the ffmpeg binary that the ``imageio-ffmpeg`` wheel
ships. Codecs are lossy: a pair that went through a video file is not bit for bit the
pair that was encoded, so its disparities are close to, not equal to, those of the
original frames.
"""

import dataclasses
import math
import os
import re
import subprocess
import tempfile
import time
from collections.abc import Callable, Iterator
from fractions import Fraction
from pathlib import Path

import numpy as np

from dcstereo import geometry, io
from dcstereo._checks import is_number
from dcstereo._extras import require
from dcstereo.api import match
from dcstereo.batch.folders import (
    ASSUMED_OPTIONS,
    FailureRow,
    check_recorded_options,
    check_threads,
    companion_options,
    make_output_folder,
    numba_threads,
    write_companions,
    write_failures,
)
from dcstereo.costs.row_offsets import moved_view
from dcstereo.methods.sgm import sgm_row_field
from dcstereo.params import SGM_METHODS, MatchParams, spelled_out
from dcstereo.refine.confidence import confidence as confidence_map

#: File suffixes taken as frames in a frame folder.
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".pgm", ".ppm", ".pfm")

#: What a sequence's ``batch.json`` records besides the matching options, and the value
#: assumed when it does not (one written before these were recorded): the defaults.
WRITE_OPTIONS = {"disparity_format": "pfm", "preview_style": "paper"}

_VIDEO_SIZE = re.compile(r"Stream #.*?Video:.*?(\d{2,5})x(\d{2,5})")


@dataclasses.dataclass(frozen=True)
class Frame:
    """One frame of a sequence: its index, name, and a function that returns the pair.

    ``load()`` returns ``(left, right)`` arrays or raises ``ValueError`` (a frame of a
    folder that cannot be read); for videos the pair is already decoded.
    """

    index: int
    name: str
    source: str
    load: Callable[[], tuple[np.ndarray, np.ndarray]]


@dataclasses.dataclass(frozen=True)
class StereoSequence:
    """A stereo sequence opened by :func:`open_sequence`.

    Attributes
    ----------
    kind : str
        ``"folders"``, ``"videos"`` or ``"side-by-side"``.
    frame_count : int
        Number of frames.
    fps : float or None
        Frame rate of a video source (None for folders).
    """

    kind: str
    frame_count: int
    fps: float | None
    _frames: Callable[[], Iterator[Frame]]

    def __len__(self) -> int:
        """Return the number of frames."""
        return self.frame_count

    def frames(self) -> Iterator[Frame]:
        """Yield the frames in order (videos are decoded once, as they are read)."""
        return self._frames()


def frame_name(index: int) -> str:
    """Return the output stem of frame ``index`` (``frame00042``)."""
    return f"frame{index:05d}"


def open_sequence(left: str | os.PathLike, right: str | os.PathLike | None = None):
    """Open a stereo sequence.

    Parameters
    ----------
    left : str or os.PathLike
        A folder of left frames, the left video, or (with ``right`` None) one
        side-by-side video whose left half is the left view.
    right : str or os.PathLike, optional
        The folder of right frames or the right video.

    Returns
    -------
    StereoSequence

    Raises
    ------
    ValueError
        For missing inputs, folders with different frame counts or no frames, videos
        with different frame counts or sizes, or a side-by-side video of odd width.
    """
    left = Path(left)
    if not left.exists():
        raise ValueError(f"cannot read sequence '{left}': no such file or folder")
    if right is not None:
        right = Path(right)
        if not right.exists():
            raise ValueError(f"cannot read sequence '{right}': no such file or folder")
    if left.is_dir():
        if right is None:
            raise ValueError(f"'{left}' is a folder of frames: give the folder of right frames")
        if not right.is_dir():
            raise ValueError(
                f"left '{left}' is a folder of frames, so right '{right}' must be a folder too"
            )
        return _folder_sequence(left, right)
    if right is not None and right.is_dir():
        raise ValueError(f"left '{left}' is a video, so right '{right}' must be a video too")
    if right is None:
        return _side_by_side_sequence(left)
    return _video_pair_sequence(left, right)


def _frame_files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES)


def _folder_sequence(left_dir: Path, right_dir: Path) -> StereoSequence:
    lefts, rights = _frame_files(left_dir), _frame_files(right_dir)
    if not lefts:
        raise ValueError(f"folder '{left_dir}' holds no frames ({', '.join(IMAGE_SUFFIXES)})")
    if len(lefts) != len(rights):
        raise ValueError(
            f"'{left_dir}' holds {len(lefts)} frames but '{right_dir}' holds {len(rights)}"
        )

    def frames():
        for index, (lp, rp) in enumerate(zip(lefts, rights, strict=True)):
            yield Frame(
                index,
                frame_name(index),
                f"{lp} | {rp}",
                lambda lp=lp, rp=rp: (io.read_image(lp), io.read_image(rp)),
            )

    return StereoSequence("folders", len(lefts), None, frames)


def _video_pair_sequence(left: Path, right: Path) -> StereoSequence:
    (n_left, fps, size_left), (n_right, _, size_right) = _probe(left), _probe(right)
    if n_left != n_right or size_left != size_right:
        raise ValueError(
            f"videos differ: '{left}' has {n_left} frames of {size_left[0]}x{size_left[1]}, "
            f"'{right}' {n_right} of {size_right[0]}x{size_right[1]}"
        )

    def frames():
        pairs = zip(read_video(left), read_video(right), strict=True)
        for index, (lf, rf) in enumerate(pairs):
            yield Frame(index, frame_name(index), f"{left.name}#{index}", lambda a=lf, b=rf: (a, b))

    return StereoSequence("videos", n_left, fps, frames)


def _side_by_side_sequence(path: Path) -> StereoSequence:
    count, fps, (width, _) = _probe(path)
    if width % 2:
        raise ValueError(f"side-by-side video '{path}' has an odd width ({width} pixels)")
    half = width // 2

    def frames():
        for index, frame in enumerate(read_video(path)):
            yield Frame(
                index,
                frame_name(index),
                f"{path.name}#{index}",
                lambda f=frame: (f[:, :half], f[:, half:]),
            )

    return StereoSequence("side-by-side", count, fps, frames)


def _ffmpeg() -> str:
    imageio_ffmpeg = require("imageio_ffmpeg", "video", "video files")

    return imageio_ffmpeg.get_ffmpeg_exe()


def _probe(path: Path) -> tuple[int, float, tuple[int, int]]:
    """Return ``(frame_count, fps, (width, height))`` of a video."""
    imageio_ffmpeg = require("imageio_ffmpeg", "video", "video files")

    if not path.exists():
        raise ValueError(f"cannot read video '{path}': no such file")
    if path.is_dir():
        raise ValueError(f"cannot read video '{path}': it is a folder")

    info = subprocess.run(
        [_ffmpeg(), "-hide_banner", "-nostdin", "-i", str(path)],
        capture_output=True,
        text=True,
        errors="replace",
        check=False,
    ).stderr
    size = _VIDEO_SIZE.search(info)
    if size is None:
        raise ValueError(f"cannot read video '{path}': no video stream found")
    fps = re.search(r"(\d+(?:\.\d+)?) fps", info)
    try:
        count, _ = imageio_ffmpeg.count_frames_and_secs(str(path))
    except (RuntimeError, subprocess.CalledProcessError) as exc:
        raise ValueError(f"cannot read video '{path}': {exc}") from None
    return count, float(fps[1]) if fps else 25.0, (int(size[1]), int(size[2]))


def read_video(path: str | os.PathLike) -> Iterator[np.ndarray]:
    """Yield the frames of a video as uint8 RGB arrays of shape (H, W, 3).

    Runs imageio-ffmpeg's ffmpeg in a subprocess that is always closed, also when the
    caller stops early.
    """
    path = Path(path)
    _, _, (width, height) = _probe(path)
    size = width * height * 3
    command = [_ffmpeg(), "-nostdin", "-v", "error", "-i", str(path)]
    command += ["-f", "rawvideo", "-pix_fmt", "rgb24", "-"]
    with tempfile.TemporaryFile() as log:
        with subprocess.Popen(
            command, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=log
        ) as process:
            try:
                while True:
                    data = process.stdout.read(size)
                    if len(data) < size:
                        break
                    yield np.frombuffer(data, dtype=np.uint8).reshape(height, width, 3)
            finally:
                if process.poll() is None:
                    process.kill()
        if process.returncode not in (0, -9):
            log.seek(0)
            message = log.read().decode(errors="replace").strip().splitlines()
            raise ValueError(
                f"cannot read video '{path}': {message[-1] if message else 'ffmpeg failed'}"
            )


def write_video(path: str | os.PathLike, frames, *, fps: float = 10.0, quality: float = 8.0) -> int:
    """Write uint8 frames (H, W) or (H, W, 3) as an H.264 video, atomically.

    Odd sizes are padded by one row or column (edge pixels): the encoder needs even
    sizes. The frames go to imageio-ffmpeg's ffmpeg (libx264, yuv420p); when ffmpeg
    fails (a suffix it knows no container for, a frame too large for the codec...) its
    reason is raised and nothing is written.

    Parameters
    ----------
    path : str or os.PathLike
        Output file; its suffix picks the container (``.mp4``, ``.mkv``, ``.avi``).
    frames : iterable of ndarray
        Non-empty uint8 frames of one size.
    fps : float
        Frame rate, positive.
    quality : float
        0 (worst) to 10 (best), as imageio-ffmpeg maps it to libx264's CRF
        (``int((1 - quality / 10) * 51)``).

    Returns
    -------
    int
        Number of frames written.

    Raises
    ------
    TypeError
        For a frame that is not uint8, an ``fps`` or ``quality`` that is not a number.
    ValueError
        For no frames, frames of other shapes or sizes, an ``fps`` or ``quality`` out of
        range, or when ffmpeg fails.
    """
    for name, value in (("fps", fps), ("quality", quality)):
        if not is_number(value):
            raise TypeError(f"{name} must be a number, got {value!r}")
    if not 0 < fps < math.inf:
        raise ValueError(f"fps must be a positive finite number, got {fps}")
    if not 0 <= quality <= 10:
        raise ValueError(f"quality must be from 0 to 10, got {quality}")
    rate = str(Fraction(float(fps)).limit_denominator())
    crf = str(int((1 - quality / 10.0) * 51))  # imageio-ffmpeg's mapping
    count, process, shape, pad = 0, None, None, None
    with io.atomic_write(path) as tmp, tempfile.TemporaryFile() as log:
        try:
            for frame in frames:
                frame = _video_frame(frame, count, path)
                if process is None:
                    shape = frame.shape
                    pad = ((0, shape[0] % 2), (0, shape[1] % 2), (0, 0))
                    size = f"{shape[1] + pad[1][1]}x{shape[0] + pad[0][1]}"
                    command = [_ffmpeg(), "-y", "-f", "rawvideo", "-vcodec", "rawvideo"]
                    command += ["-s", size, "-pix_fmt", "rgb24", "-r", rate, "-i", "-", "-an"]
                    command += ["-vcodec", "libx264", "-pix_fmt", "yuv420p", "-crf", crf]
                    command += ["-v", "error", str(tmp)]
                    process = subprocess.Popen(
                        command, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=log
                    )
                elif frame.shape != shape:
                    raise ValueError(
                        f"cannot write video '{path}': frame {count} has shape {frame.shape}, "
                        f"the first {shape}"
                    )
                try:
                    process.stdin.write(np.ascontiguousarray(np.pad(frame, pad, mode="edge")))
                except BrokenPipeError:
                    break  # ffmpeg stopped: its reason is in the log
                count += 1
        except BaseException:
            if process is not None:
                process.kill()
                _finish_ffmpeg(process)
            raise
        if process is None:
            raise ValueError(f"cannot write video '{path}': no frames")
        if _finish_ffmpeg(process) != 0:
            raise ValueError(f"cannot write video '{path}': {_ffmpeg_reason(log)}")
    return count


def _video_frame(frame, index: int, path) -> np.ndarray:
    """Check one frame of :func:`write_video`; return it as (H, W, 3) uint8."""
    frame = np.asarray(frame)
    if frame.dtype != np.uint8:
        raise TypeError(
            f"cannot write video '{path}': frame {index} must be uint8, got dtype {frame.dtype}"
        )
    if frame.ndim == 2:
        frame = np.repeat(frame[:, :, None], 3, axis=2)
    elif not (frame.ndim == 3 and frame.shape[2] == 3):
        raise ValueError(
            f"cannot write video '{path}': frame {index} must have shape (H, W) or (H, W, 3), "
            f"got {frame.shape}"
        )
    if frame.size == 0:
        raise ValueError(f"cannot write video '{path}': frame {index} is empty ({frame.shape})")
    return frame


def _finish_ffmpeg(process: subprocess.Popen) -> int:
    """Close ffmpeg's input, wait for it and return its exit status."""
    try:
        process.stdin.close()
    except OSError:  # the pipe is broken: ffmpeg has already stopped
        pass
    return process.wait()


def _ffmpeg_reason(log) -> str:
    """Return the first line ffmpeg wrote to ``log``, without its ``[name @ 0x...]`` tags."""
    log.seek(0)
    text = log.read().decode(errors="replace")
    lines = (re.sub(r"^(\[[^\]]*\]\s*)+", "", line).strip() for line in text.splitlines())
    return next((line for line in lines if line), "ffmpeg failed")


@dataclasses.dataclass
class SequenceReport:
    """What :func:`match_sequence` did: frame names per outcome, and failures."""

    done: list[str] = dataclasses.field(default_factory=list)
    skipped: list[str] = dataclasses.field(default_factory=list)
    failed: list[FailureRow] = dataclasses.field(default_factory=list)
    seconds: float = 0.0

    @property
    def ok(self) -> bool:
        """True when no frame failed."""
        return not self.failed


def output_paths(output_dir: str | os.PathLike, index: int, fmt: str = "pfm"):
    """Return ``(disparity, preview)`` paths of frame ``index`` in ``output_dir``."""
    stem = Path(output_dir) / frame_name(index)
    return stem.with_name(f"{stem.name}.{fmt}"), stem.with_name(f"{stem.name}-preview.png")


def depth_output_path(output_dir: str | os.PathLike, index: int, depth_format: str = "pfm") -> Path:
    """Return the depth map's path of frame ``index`` (``frameNNNNN-depth.pfm|png``)."""
    return Path(output_dir) / f"{frame_name(index)}-depth.{depth_format}"


def confidence_output_path(output_dir: str | os.PathLike, index: int) -> Path:
    """Return the confidence map's path of frame ``index`` (``frameNNNNN-confidence.pfm``)."""
    return Path(output_dir) / f"{frame_name(index)}-confidence.pfm"


def cloud_output_path(output_dir: str | os.PathLike, index: int) -> Path:
    """Return the point cloud's path of frame ``index`` (``frameNNNNN.ply``)."""
    return Path(output_dir) / f"{frame_name(index)}.ply"


def match_sequence(
    sequence: StereoSequence,
    output_dir: str | os.PathLike,
    *,
    max_disparity: int,
    client=None,
    resume: bool = True,
    disparity_format: str = "pfm",
    preview_style: str = "paper",
    threads: int | None = None,
    on_frame: Callable[[str, str], None] | None = None,
    calibration: geometry.Calibration | None = None,
    confidence: bool = False,
    ply: bool = False,
    depth_format: str = "pfm",
    depth_scale: float | None = None,
    recording=None,
    **options,
) -> SequenceReport:
    """Match every frame of a sequence; write its disparity and preview atomically.

    Parameters
    ----------
    sequence : StereoSequence
        From :func:`open_sequence`.
    output_dir : str or os.PathLike
        Folder for ``frameNNNNN.pfm|png``, ``frameNNNNN-preview.png``, ``failures.csv``
        and ``batch.json`` (the options, ``disparity_format`` and ``preview_style``
        included, checked when resuming; a ``batch.json`` without the last two is taken
        as made with their defaults); created, with its parents, once the options are
        found valid.
    max_disparity : int
        Largest disparity searched.
    client : distributed.Client, optional
        Run one task per frame on this client (frames are decoded here and sent to the
        workers; a few frames are in flight at a time). None: match here.
    resume : bool
        Skip frames whose two outputs exist and are complete
        (:func:`dcstereo.io.is_complete`; an incomplete one is redone and
        counted as done); False recomputes every frame.
    disparity_format : {"pfm", "png"}
        PFM (float32, ``inf`` = no estimate) or 16-bit PNG (``d * 256``, 0 = none; the
        range must then lie in 0..255).
    preview_style : {"paper", "color"}
        See :func:`dcstereo.viz.preview`.
    threads : int, optional
        numba threads per frame; default all cores here, 1 inside a Dask task. numba's
        count is restored after each frame.
    on_frame : callable, optional
        Called as ``on_frame(name, status)`` (``"done"``, ``"skipped"``, ``"failed"``).
    calibration : Calibration, optional
        The rig's geometry: also write each frame's depth map
        (:func:`dcstereo.geometry.depth`) as ``frameNNNNN-depth.pfm`` (float32, in the
        baseline's unit, ``inf`` = none). A frame is then complete only when its three
        files are; ``batch.json`` records the calibration.
    confidence : bool
        Also write each frame's confidence map (:func:`dcstereo.refine.confidence.confidence`)
        as ``frameNNNNN-confidence.pfm`` (``inf`` = none); a frame is then complete only
        with it.
    depth_format : {"pfm", "png"}
        With ``calibration``: ``frameNNNNN-depth.pfm`` (float32) or ``-depth.png`` (16
        bits of ``round(z * depth_scale)``, 0 = none; see
        :func:`dcstereo.io.write_depth_png16`).
    depth_scale : float, optional
        With ``depth_format="png"``: stored value per unit of depth (default 1).
    ply : bool
        Also write each frame's point cloud (:func:`dcstereo.geometry.point_cloud`,
        coloured by the left frame when it is 8 or 16 bits; binary PLY) as
        ``frameNNNNN.ply``; needs ``calibration``, and a frame is then complete only with
        it.
    recording : rerun.RecordingStream, optional
        Also log each frame matched to this Rerun recording
        (:func:`dcstereo.viz.rerun_recording`) with :func:`dcstereo.viz.log_rerun`, at
        its index on the ``frame`` time line: the left view, the disparity, the occlusion
        and confidence maps (the confidence is computed for it) and, with
        ``calibration``, the camera, the depth and the point cloud. Frames skipped on
        resume are not logged (``resume=False`` logs every frame).
    **options
        The other options of :func:`dcstereo.match`. ``row_alignment="estimated"`` (``sgm``)
        measures the rows' offsets once, on the first frame this call matches
        (:func:`dcstereo.methods.sgm.sgm_row_field`), and moves every frame's right view by
        them (:func:`dcstereo.costs.row_offsets.moved_view`): one rig, one field, so that
        frames do not flicker between moved and not and pay for it once.

    Returns
    -------
    SequenceReport

    Raises
    ------
    ValueError
        For options :func:`dcstereo.match` refuses, an unknown format or preview style,
        a range the PNG format cannot store, a ``threads`` out of range, an output
        folder that is a file or cannot be created, or, when resuming,
        outputs made with other options or an unreadable ``batch.json`` (before any
        frame runs; bad options leave no folder).
    """
    from dcstereo.viz import check_preview_style, preview

    start = time.perf_counter()
    folder = Path(output_dir)
    if not isinstance(sequence, StereoSequence):
        raise TypeError(
            f"sequence must be a StereoSequence (from open_sequence), got {type(sequence).__name__}"
        )
    if disparity_format not in ("pfm", "png"):
        raise ValueError(f"disparity_format must be 'pfm' or 'png', got {disparity_format!r}")
    check_preview_style(preview_style, "preview_style")
    companions = companion_options(
        calibration is not None, calibration, confidence, ply,
        depth_format=depth_format, depth_scale=depth_scale,
    )  # fmt: skip
    if ply and calibration is None:
        raise ValueError("ply=True needs a calibration (the point clouds' geometry)")
    check_threads(threads, client)
    params = MatchParams(max_disparity=max_disparity, **options)
    if disparity_format == "png" and (params.min_disparity < 0 or params.max_disparity > 255):
        raise ValueError(
            f"disparity_format 'png' stores disparities 0 to 255 (16 bits at scale 256), not "
            f"{params.min_disparity}..{params.max_disparity}; use 'pfm'"
        )
    make_output_folder(folder)
    written = {"disparity_format": disparity_format, "preview_style": preview_style}
    written.update(companions)
    check_recorded_options(
        folder,
        {**dataclasses.asdict(params), **written},
        resume,
        assumed={**ASSUMED_OPTIONS, **WRITE_OPTIONS},
    )
    match_kwargs = spelled_out({"max_disparity": max_disparity, **options})
    align_once = params.method in SGM_METHODS and params.row_alignment == "estimated"
    if align_once:  # measured on the first frame matched, for all (by frame size)
        match_kwargs["row_alignment"] = None
    fields = {}

    def aligned(left, right):
        if not align_once:
            return right
        size = left.shape[:2]
        if size not in fields:
            field = sgm_row_field(left, right, params)
            fields[size] = None if field is None else field.to_move()
        return right if fields[size] is None else moved_view(right, fields[size])

    report = SequenceReport()
    # the viewer gets each frame's confidence, and its left view for the picture and colours
    sure_wanted = confidence or recording is not None
    keep_left = ply or recording is not None

    def note(name, status):
        if on_frame is not None:
            on_frame(name, status)

    def finish(frame, answer, left=None):
        disparity, occluded, detail, sure = answer
        if disparity is None:
            report.failed.append(FailureRow(frame.name, frame.source, "", detail))
            note(frame.name, "failed")
            return
        disparity_path, preview_path = output_paths(folder, frame.index, disparity_format)
        colors = left if left is not None and left.dtype.kind == "u" else None
        write_companions(
            disparity,
            calibration,
            depth_output_path(folder, frame.index, depth_format),
            sure if confidence else None,
            confidence_output_path(folder, frame.index),
            (cloud_output_path(folder, frame.index), colors) if ply else None,
            depth_scale,
        )
        io.write_disparity(disparity_path, disparity)
        io.write_rgb_png(preview_path, preview(disparity, occluded, style=preview_style))
        if recording is not None:
            from dcstereo.viz import log_rerun

            log_rerun(
                disparity,
                left,
                recording=recording,
                calibration=calibration,
                confidence=sure,
                occluded=occluded,
                disparity_range=(params.min_disparity, params.max_disparity),
                frame=frame.index,
            )
        report.done.append(frame.name)
        note(frame.name, "done")

    def frame_outputs(index):
        outputs = list(output_paths(folder, index, disparity_format))
        if calibration is not None:
            outputs.append(depth_output_path(folder, index, depth_format))
        if confidence:
            outputs.append(confidence_output_path(folder, index))
        if ply:
            outputs.append(cloud_output_path(folder, index))
        return outputs

    # what a killed run left half-written (never a real output), the folder listed once
    io.remove_stale_temporaries(
        *(path for index in range(sequence.frame_count) for path in frame_outputs(index))
    )

    def pending():
        for frame in sequence.frames():
            outputs = frame_outputs(frame.index)
            if resume and all(io.is_complete(p) for p in outputs):
                report.skipped.append(frame.name)
                note(frame.name, "skipped")
                continue
            try:
                left, right = frame.load()
                right = aligned(left, right)
            except ValueError as exc:
                finish(frame, (None, None, str(exc), None))
                continue
            yield frame, left, right

    if client is None:
        for frame, left, right in pending():
            finish(frame, match_frame(left, right, match_kwargs, threads, sure_wanted), left)
    else:
        _run_on_dask(client, pending(), match_kwargs, threads, sure_wanted, finish, keep_left)
    report.done.sort()
    write_failures(folder, report.failed)
    report.seconds = time.perf_counter() - start
    return report


def match_frame(
    left, right, match_kwargs: dict, threads: int | None = None, confidence: bool = False
):
    """Match one frame; return ``(disparity, occluded, seconds, sure)``.

    ``sure`` is the confidence map when ``confidence``, else None; a frame that cannot be
    matched gives ``(None, None, reason, None)``.
    """
    with numba_threads(threads):
        start = time.perf_counter()
        try:
            result = match(left, right, **match_kwargs)
        except (ValueError, TypeError) as exc:
            return None, None, str(exc).strip().splitlines()[0], None
        sure = confidence_map(result, left, right) if confidence else None
        return result.disparity, result.occluded, time.perf_counter() - start, sure


def _run_on_dask(client, frames, match_kwargs, threads, confidence, finish, keep_left=False):
    """Match the frames on the cluster, a few in flight; ``finish(frame, answer, left)``.

    ``left`` is the frame's left view when ``keep_left`` (a cloud's colours), else None.
    """
    from distributed import as_completed

    workers = max(1, len(client.scheduler_info().get("workers", {})))
    in_flight = 2 * workers  # frames decoded ahead; bounds the memory held here
    owner = {}
    queue = as_completed()

    def submit(item):
        frame, left, right = item
        left_f, right_f = client.scatter([left, right])
        future = client.submit(
            match_frame,
            left_f,
            right_f,
            match_kwargs,
            1 if threads is None else threads,
            confidence,
            key=f"dcstereo-frame-{frame.name}-{os.urandom(4).hex()}",
            retries=2,
        )
        owner[future.key] = (frame, left if keep_left else None)
        queue.add(future)

    frames = iter(frames)
    for item in frames:
        submit(item)
        if queue.count() >= in_flight:
            break
    for future in queue:
        frame, left = owner.pop(future.key)
        try:
            answer = future.result()
        except Exception as exc:  # the task failed for good (KilledWorker, ...)
            reason = f"task failed on the cluster: {type(exc).__name__}: {exc}"
            answer = (None, None, reason, None)
        future.release()
        finish(frame, answer, left)
        item = next(frames, None)
        if item is not None:
            submit(item)
