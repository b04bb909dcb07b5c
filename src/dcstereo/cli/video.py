"""``dcstereo video``: a disparity and a preview per frame of a stereo sequence."""

from contextlib import nullcontext
from pathlib import Path

import click

from dcstereo.cli._common import (
    CommandError,
    apply_threads,
    check_output_paths,
    check_rerun,
    compile_watch,
    depth_file_options,
    disparity_range_options,
    matching_options,
    one_line_errors,
    output_folder,
    preview_style_option,
    rerun_options,
)
from dcstereo.cli.batch import advancer, dask_client, progress_bar, scheduler_option


@click.command()
@click.argument("left", type=click.Path(exists=True))
@click.argument("right", type=click.Path(exists=True), required=False)
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(file_okay=False),
    help="Folder for frameNNNNN.pfm|png and frameNNNNN-preview.png (created if missing).",
)
@disparity_range_options
@matching_options
@click.option(
    "--format",
    "disparity_format",
    type=click.Choice(["pfm", "png"]),
    default="pfm",
    show_default=True,
    help="Disparity files: PFM (float32, inf = none) or 16-bit PNG (d * 256, 0 = none).",
)
@preview_style_option
@click.option(
    "--preview-video",
    type=click.Path(dir_okay=False),
    default=None,
    help="Also write the previews as a video (.mp4, .mkv, .avi).",
)
@click.option(
    "--fps",
    type=float,
    default=None,
    help="Frame rate of the preview video (default: the input video's, or 10).",
)
@click.option(
    "--calib",
    type=click.Path(dir_okay=False),
    default=None,
    help="The rig's calibration (Middlebury's calib.txt format): also write each frame's "
    "depth map, frameNNNNN-depth.pfm (float32, in the baseline's unit, inf = none).",
)
@click.option(
    "--confidence",
    is_flag=True,
    help="Also write each frame's confidence map, frameNNNNN-confidence.pfm (-1..1, "
    "inf = none; see dcstereo.refine.confidence).",
)
@depth_file_options
@click.option(
    "--ply",
    is_flag=True,
    help="With --calib: also write each frame's point cloud, frameNNNNN.ply (binary PLY, "
    "left camera frame, coloured by the left view).",
)
@rerun_options
@scheduler_option
@click.option(
    "--resume/--no-resume",
    default=True,
    show_default=True,
    help="Skip frames whose outputs are already complete; --no-resume recomputes all.",
)
@click.option("--quiet", "-q", is_flag=True, help="No progress bar; print only failures.")
@one_line_errors
def video(
    left,
    right,
    output,
    max_disparity,
    min_disparity,
    match_options,
    threads,
    disparity_format,
    preview_style,
    preview_video,
    fps,
    calib,
    confidence,
    ply,
    depth_format,
    depth_scale,
    rerun_out,
    rerun_spawn,
    scheduler,
    resume,
    quiet,
):
    """Match every frame of a stereo sequence.

    LEFT and RIGHT are two folders of frames (paired in name order) or two videos;
    LEFT alone is a side-by-side video (left view in the left half). A frame that fails
    is reported (and listed in OUTPUT/failures.csv) while the others go on; the exit
    code is 1 when any frame failed.
    """
    from dcstereo.batch.folders import FAILURES_FILE
    from dcstereo.batch.video import match_sequence, open_sequence, output_paths, write_video
    from dcstereo.geometry import Calibration
    from dcstereo.params import MatchParams
    from dcstereo.viz import rerun_recording

    folder = output_folder(output)
    if preview_video is not None:
        if Path(preview_video).suffix.lower() not in (".mp4", ".mkv", ".avi", ".mov"):
            raise CommandError(f"--preview-video '{preview_video}' must end in .mp4, .mkv, .avi")
        parent = Path(preview_video).parent.resolve()
        made = (folder.resolve(), *folder.resolve().parents)  # exist once OUTPUT is made
        if not parent.is_dir() and parent not in made:
            raise CommandError(
                f"cannot write '{preview_video}': '{Path(preview_video).parent}' does not exist"
            )
    if fps is not None and not fps > 0:
        raise CommandError(f"--fps must be positive, got {fps}")
    if ply and calib is None:
        raise CommandError("--ply needs --calib (the point clouds' geometry)")
    if depth_format != "pfm" and calib is None:
        raise CommandError("--depth-format is used only with --calib (the depth maps)")
    if depth_scale is not None and depth_format != "png":
        raise CommandError("--depth-scale is used only with --depth-format png")
    if rerun_out is not None:
        from dcstereo import io

        io.check_suffix(rerun_out, ".rrd", "--rerun")
        check_output_paths(rerun_out)  # its folder must exist: it is written as frames come
    if rerun_out is not None or rerun_spawn:
        check_rerun()
    calibration = None if calib is None else Calibration.from_middlebury(calib)
    sequence = open_sequence(left, right)
    # Refuse bad options before a cluster starts; match_sequence makes the folder once valid.
    MatchParams(max_disparity=max_disparity, min_disparity=min_disparity, **match_options)
    apply_threads(threads, scheduler)
    # compile_watch: a first run's compiling is announced (here, not on a Dask cluster)
    viewing = rerun_out is not None or rerun_spawn
    with (
        progress_bar("frames", quiet) as bar,
        dask_client(scheduler) as client,
        compile_watch(quiet),
        rerun_recording(rerun_out, spawn=rerun_spawn) if viewing else nullcontext() as recording,
    ):
        report = match_sequence(
            sequence,
            folder,
            max_disparity=max_disparity,
            client=client,
            resume=resume,
            disparity_format=disparity_format,
            preview_style=preview_style,
            threads=threads if scheduler is not None else None,
            on_frame=advancer(bar, "video", len(sequence)),
            calibration=calibration,
            confidence=confidence,
            ply=ply,
            depth_format=depth_format,
            depth_scale=depth_scale,
            min_disparity=min_disparity,
            recording=recording,
            **match_options,
        )
    written = None
    if preview_video is not None:
        from dcstereo import io

        previews = [output_paths(folder, i, disparity_format)[1] for i in range(len(sequence))]
        previews = [p for p in previews if p.is_file()]
        rate = fps or sequence.fps or 10.0
        written = write_video(preview_video, (io.read_image(p) for p in previews), fps=rate)
    for row in report.failed:
        click.echo(f"failed: {row.name} ({row.left}): {row.error}", err=True)
    if not quiet:
        matched = len(report.done)
        rate = f", {matched / report.seconds:.1f} frames/s" if matched and report.seconds else ""
        click.echo(
            f"video: {len(sequence)} frames ({sequence.kind}), {matched} matched, "
            f"{len(report.skipped)} already complete, {len(report.failed)} failed, "
            f"{report.seconds:.1f} s{rate} -> {folder}"
            + (f", preview video {preview_video} ({written} frames)" if written else "")
            + (f", Rerun recording {rerun_out} ({matched} frames)" if rerun_out else "")
        )
    if not report.ok:
        click.echo(
            f"Error: {len(report.failed)} of {len(sequence)} frames failed; "
            f"see {folder / FAILURES_FILE}",
            err=True,
        )
        raise SystemExit(1)
