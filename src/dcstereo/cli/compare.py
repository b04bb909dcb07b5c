"""``dcstereo compare``: the paper's Fig. 4 / 6 on a real pair, one column per method."""

import click

from dcstereo.cli._common import (
    add_method_options,
    check_distinct_paths,
    check_method_options,
    check_output_paths,
    compile_watch,
    disparity_range_options,
    one_line_errors,
    set_threads,
)


@click.command()
@click.argument("left", type=click.Path(dir_okay=False))
@click.argument("right", type=click.Path(dir_okay=False))
@click.option(
    "-o", "--output", required=True, type=click.Path(dir_okay=False), help="The figure, .png."
)
@disparity_range_options
@click.option(
    "--gt",
    type=click.Path(),
    default=None,
    help="Ground truth: a scene folder (any layout; its nonocc mask is scored) or a "
    "disparity file (PFM, 16-bit PNG, or 8-bit PNG with --gt-scale).",
)
@click.option(
    "--gt-scale",
    type=float,
    default=None,
    help="Gray value per pixel of disparity of the --gt file.",
)
@click.option(
    "--methods",
    default="dsi3,dsi5,dc",
    show_default=True,
    help="Comma-separated methods, one column each (any of dcstereo's, opencv-sgbm, "
    "opencv-bm; all: every one).",
)
@click.option(
    "--window",
    type=int,
    default=None,
    help="Odd window side, for every method (default: each method's own).",
)
@click.option("--threads", type=int, default=None, help="Number of threads (default: all).")
@add_method_options
@one_line_errors
def compare(
    left, right, output, max_disparity, min_disparity, gt, gt_scale, methods, window, threads,
    method_options,
):  # fmt: skip
    """Match LEFT/RIGHT with each method and lay out the maps side by side in OUTPUT.

    Rows: the paper's display (histogram-equalized, occlusions white), the filled map in
    colour and, with --gt, the error map (red: wrong by more than 1 pixel). A method's own
    options (--ser-min and the others of run) reach the methods that read them.
    """
    from pathlib import Path

    from dcstereo import io
    from dcstereo.evaluation.datasets import load_scene
    from dcstereo.evaluation.scoring import parse_methods
    from dcstereo.viz.explore import compare_figure, compare_methods

    if gt_scale is not None and gt is None:
        raise click.UsageError("--gt-scale needs --gt")
    gt_is_scene = gt is not None and Path(gt).is_dir()
    io.check_png_suffix(output, "--output")
    check_output_paths(output)
    check_distinct_paths(
        {
            "the left input": left,
            "the right input": right,
            "the --gt scene folder" if gt_is_scene else "the --gt file": gt,
        },
        {"--output": output},
    )
    names = parse_methods(methods)
    check_method_options(method_options, names)
    set_threads(threads)
    left_image = io.read_image(left)
    right_image = io.read_image(right)
    truth = mask = None
    if gt is not None:
        if gt_is_scene:
            scene = load_scene(gt)
            # nonocc where the scene has it; else every pixel with ground truth
            truth, mask = scene.disparity, scene.masks.get("nonocc")
        else:
            truth = io.read_disparity(gt, scale=gt_scale)
    with compile_watch():  # each method's first run on a machine compiles it
        results = compare_methods(
            left_image,
            right_image,
            max_disparity=max_disparity,
            min_disparity=min_disparity,
            methods=names,
            match_options=method_options,
            **({} if window is None else {"window": window}),
        )
    figure = compare_figure(
        left_image, results, max_disparity=max_disparity, truth=truth, mask=mask
    )
    io.write_rgb_png(output, figure)
    click.echo(f"{', '.join(names)}: {figure.shape[1]}x{figure.shape[0]} figure -> {output}")
