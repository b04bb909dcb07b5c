"""``dcstereo run``: match one rectified pair and write the disparity and its companions."""

import functools
import math
import time

import click

from dcstereo.cli._common import (
    FEATURE_METHODS,
    calibration_of,
    calibration_options,
    check_distinct_paths,
    check_output_paths,
    check_rerun,
    compile_note,
    compile_watch,
    disparity_range_options,
    matching_options,
    one_line_errors,
    preview_style_option,
    record_rerun,
    rerun_options,
    set_threads,
    staged_outputs,
)


@click.command()
@click.argument("left", type=click.Path(dir_okay=False))
@click.argument("right", type=click.Path(dir_okay=False))
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(dir_okay=False),
    help="Disparity output: .pfm (float32, inf = no estimate) or .png (16-bit, d * 256, "
    "0 = no estimate).",
)
@disparity_range_options
@matching_options
@click.option(
    "--occlusion-out",
    type=click.Path(dir_okay=False),
    default=None,
    help="Write the occlusion map (PNG, 255 = left pixel without a partner).",
)
@click.option(
    "--preview",
    type=click.Path(dir_okay=False),
    default=None,
    help="Write a preview PNG of the disparity.",
)
@preview_style_option
@click.option(
    "--features-out",
    type=click.Path(dir_okay=False),
    default=None,
    help="Write the accepted feature pairs as CSV (dc methods).",
)
@click.option(
    "--draw-features",
    is_flag=True,
    help="Mark the accepted feature pairs in red on the preview (dc methods; needs --preview).",
)
@click.option(
    "--depth-out",
    type=click.Path(dir_okay=False),
    default=None,
    help="Write the depth map: .pfm (float32, in the baseline's unit, inf = no depth) or "
    ".png (16-bit, depth * --depth-scale, 0 = no depth); needs a calibration.",
)
@click.option(
    "--depth-scale",
    type=float,
    default=None,
    help="Stored value per unit of depth in a .png --depth-out (default 1: millimetres "
    "for a baseline in mm; 1000 for a baseline in metres).",
)
@click.option(
    "--ply",
    "ply_out",
    type=click.Path(dir_okay=False),
    default=None,
    help="Write the 3-D points of the pixels with a depth, coloured by LEFT (binary "
    "PLY, left camera frame: x right, y down, z forward); needs a calibration.",
)
@click.option(
    "--ply-min-confidence",
    type=float,
    default=None,
    help="Keep in --ply only the points whose confidence (see --confidence-out) is at "
    "least this, -1..1; filled pixels have none and are left out.",
)
@calibration_options
@click.option(
    "--rectify",
    "rectify_calib",
    multiple=True,
    type=click.Path(dir_okay=False),
    help="Rectify LEFT and RIGHT first with this calibration (an OpenCV FileStorage file "
    "with K1 D1 K2 D2 R T; give it twice for intrinsics and extrinsics files; see dcstereo "
    "rectify); its rectified geometry is the calibration of --depth-out and --ply. The "
    "outputs are in the rectified left image's geometry. Needs dcstereo[opencv].",
)
@click.option(
    "--confidence-out",
    type=click.Path(dir_okay=False),
    default=None,
    help="Write each pixel's confidence (PFM, float32 in -1..1: the margin of its "
    "disparity's cost over the best rival two or more pixels away; inf = none).",
)
@rerun_options
@click.option(
    "--tile-rows",
    type=int,
    default=None,
    help="Match in bands of this many rows (plus the window's overlap); the result is "
    "the same as untiled.",
)
@click.option("--quiet", "-q", is_flag=True, help="Print nothing on success.")
@one_line_errors
def run(
    left,
    right,
    output,
    max_disparity,
    min_disparity,
    match_options,
    threads,
    occlusion_out,
    preview,
    preview_style,
    features_out,
    draw_features,
    depth_out,
    depth_scale,
    ply_out,
    ply_min_confidence,
    calibration,
    rectify_calib,
    confidence_out,
    rerun_out,
    rerun_spawn,
    tile_rows,
    quiet,
):
    """Estimate the disparity of LEFT against RIGHT (a rectified pair).

    A left pixel (x, y) matches the right pixel (x - d, y); disparities
    MIN..MAX are searched, inclusive.
    """
    from dcstereo import io, match
    from dcstereo.geometry import depth, point_cloud
    from dcstereo.viz import draw_points
    from dcstereo.viz import preview as make_preview

    method = match_options["method"]
    if draw_features and preview is None:
        raise click.UsageError("--draw-features needs --preview")
    check_output_paths(
        output, occlusion_out, preview, features_out, depth_out, ply_out, confidence_out,
        rerun_out,
    )  # fmt: skip
    check_distinct_paths(
        {
            "the left input": left,
            "the right input": right,
            "--calib": calibration["calib"],
            **{f"--rectify {path}": path for path in rectify_calib},
        },
        {
            "--output": output,
            "--occlusion-out": occlusion_out,
            "--preview": preview,
            "--features-out": features_out,
            "--depth-out": depth_out,
            "--ply": ply_out,
            "--confidence-out": confidence_out,
            "--rerun": rerun_out,
        },
    )
    if (features_out is not None or draw_features) and method not in FEATURE_METHODS:
        raise ValueError(
            f"feature output needs a method with features ({', '.join(FEATURE_METHODS)}), "
            f"not {method}"
        )
    io.check_disparity_suffix(output)
    if occlusion_out is not None:
        io.check_png_suffix(occlusion_out, "--occlusion-out")
    if preview is not None:
        io.check_png_suffix(preview, "--preview")
    if depth_out is not None:
        io.check_suffix(depth_out, (".pfm", ".png"), "--depth-out")
    if depth_scale is not None:
        if depth_out is None or not depth_out.lower().endswith(".png"):
            raise ValueError("--depth-scale is used only with a .png --depth-out")
        if not (depth_scale > 0 and math.isfinite(depth_scale)):
            raise ValueError(f"--depth-scale must be a positive number, got {depth_scale:g}")
    if ply_out is not None:
        io.check_suffix(ply_out, ".ply", "--ply")
    if confidence_out is not None:
        io.check_suffix(confidence_out, ".pfm", "--confidence-out")
    if rerun_out is not None:
        io.check_suffix(rerun_out, ".rrd", "--rerun")
    viewing = rerun_out is not None or rerun_spawn
    if viewing:
        check_rerun()
    if ply_min_confidence is not None:
        if ply_out is None:
            raise ValueError("--ply-min-confidence is used only with --ply")
        if not -1 <= ply_min_confidence <= 1:
            raise ValueError(
                f"--ply-min-confidence must be between -1 and 1, got {ply_min_confidence:g}"
            )
    set_threads(threads)
    left_image = io.read_image(left)
    right_image = io.read_image(right)
    # the viewer shows the depth, the cloud and the camera when a calibration is given
    given = any(value is not None for value in calibration.values())
    if rectify_calib:  # the rectified pair, and its geometry as the calibration
        from dcstereo.cli.rectify import rectify_images

        if given:
            raise ValueError("--rectify gives the calibration: leave out --calib and --focal & co")
        pair = rectify_images(left_image, right_image, rectify_calib, 0.0)
        left_image, right_image = pair.left, pair.right
        camera = pair.calibration if (depth_out or ply_out or viewing) else None
    else:
        camera = calibration_of(
            calibration, left_image.shape, depth_out or ply_out or (viewing and given)
        )
    # staged outputs: written only if all succeed; the watch: the kernels' first compile
    # (about a minute) is announced, and the match's time says its share
    with compile_watch(quiet) as watch, staged_outputs() as write:
        start = time.perf_counter()
        if tile_rows is not None:
            from dcstereo.batch.tiling import match_tiled

            match = functools.partial(match_tiled, tile_rows=tile_rows)
        result = match(
            left_image,
            right_image,
            max_disparity=max_disparity,
            min_disparity=min_disparity,
            **match_options,
        )
        seconds = time.perf_counter() - start
        compiling = compile_note(watch)

        write(io.write_disparity, output, result.disparity)
        if occlusion_out is not None:
            write(io.write_mask_png, occlusion_out, result.occluded)
        if preview is not None:
            picture = make_preview(result.disparity, result.occluded, style=preview_style)
            if draw_features and len(result.features):
                picture = draw_points(
                    picture,
                    result.features[:, 1],
                    result.features[:, 0],
                    color=(255, 0, 0),
                    radius=0,
                )
            write(io.write_rgb_png, preview, picture)
        if features_out is not None:
            write(io.write_features_csv, features_out, result.features)
        if depth_out is not None:
            too_far = write(io.write_depth, depth_out, depth(result.disparity, camera),
                            scale=depth_scale)  # fmt: skip
        sure = None
        if confidence_out is not None or ply_min_confidence is not None or viewing:
            from dcstereo.refine.confidence import confidence

            sure = confidence(result, left_image, right_image)
        if confidence_out is not None:
            write(io.write_pfm, confidence_out, sure)
        if ply_out is not None:
            colors = left_image if left_image.dtype.kind == "u" else None
            keep = None if ply_min_confidence is None else sure >= ply_min_confidence
            cloud = point_cloud(result.disparity, camera, colors, mask=keep)
            write(io.write_ply, ply_out, cloud.points, cloud.colors)
        shown = {"result": result, "left": left_image, "camera": camera, "sure": sure}
        if rerun_out is not None:
            write(record_rerun, rerun_out, spawn=rerun_spawn, **shown)
        elif rerun_spawn:
            record_rerun(None, spawn=True, **shown)
    if not quiet:
        height, width = result.disparity.shape
        valid = 100.0 * result.valid.mean()
        click.echo(
            f"{method}: {width}x{height}, disparities {min_disparity}..{max_disparity}, "
            f"{seconds * 1000:.0f} ms{compiling}, {valid:.1f} % with an estimate -> {output}"
        )
        if depth_out is not None and too_far:
            click.echo(f"{too_far} pixels too far for 16 bits left out of {depth_out}")
        if ply_out is not None:
            click.echo(f"{len(cloud)} points -> {ply_out}")
        if rerun_out is not None:
            click.echo(f"Rerun recording -> {rerun_out}")
