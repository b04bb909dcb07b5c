"""``dcstereo scanline``: one row's DSI, optimal paths, feature pairs and profiles."""

import click

from dcstereo.cli._common import (
    add_method_options,
    check_distinct_paths,
    check_method_options,
    check_output_paths,
    compile_watch,
    disparity_range_options,
    one_line_errors,
)

#: Largest --width / --height: the picture is drawn in memory (4 bytes a pixel).
MAX_SIDE = 10000


@click.command()
@click.argument("left", type=click.Path(dir_okay=False))
@click.argument("right", type=click.Path(dir_okay=False))
@click.option("--row", "-y", required=True, type=int, help="The scanline (0 = top).")
@disparity_range_options
@click.option(
    "-o", "--output", required=True, type=click.Path(dir_okay=False), help="The figure, .png."
)
@click.option(
    "--methods",
    default="dsi3,dsi5,dc",
    show_default=True,
    help="Comma-separated dcstereo methods whose paths are drawn (a name may end in +bt "
    "for the Birchfield-Tomasi cost).",
)
@click.option("--window", type=int, default=5, show_default=True, help="Odd window side.")
@click.option(
    "--width",
    type=click.IntRange(200, MAX_SIDE),
    default=1200,
    show_default=True,
    help="Picture width, px.",
)
@click.option(
    "--height",
    type=click.IntRange(200, MAX_SIDE),
    default=800,
    show_default=True,
    help="Picture height, px.",
)
@add_method_options
@one_line_errors
def scanline(
    left, right, row, max_disparity, min_disparity, output, methods, window, width, height,
    method_options,
):  # fmt: skip
    """Draw row ROW of LEFT/RIGHT as the paper's Fig. 1 / 2 do.

    The disparity-space image of the row (x across, disparity up, dark = good match),
    the optimal paths of the methods, the feature pairs dc accepted (yellow circles) and
    the two intensity profiles. A method's own options (--ser-min and the others of run)
    reach the methods that read them.
    """
    from dcstereo import io
    from dcstereo.compat.opencv import OPENCV_METHODS
    from dcstereo.evaluation.scoring import parse_methods
    from dcstereo.viz.explore import scanline as gather
    from dcstereo.viz.explore import scanline_figure

    io.check_png_suffix(output, "--output")
    check_output_paths(output)
    check_distinct_paths({"the left input": left, "the right input": right}, {"--output": output})
    names = parse_methods(methods)
    if any(name in OPENCV_METHODS for name in names):
        raise ValueError("scanline draws dcstereo's methods only (OpenCV gives no path)")
    check_method_options(method_options, names)
    left_image = io.read_image(left)
    right_image = io.read_image(right)
    with compile_watch():  # each method's first run on a machine compiles it
        data = gather(
            left_image,
            right_image,
            row,
            max_disparity=max_disparity,
            min_disparity=min_disparity,
            window=window,
            methods=names,
            **method_options,
        )
    io.write_rgb_png(output, scanline_figure(data, width=width, height=height))
    pairs = sum(len(p) for p in data["features"].values())
    click.echo(f"row {row}: {', '.join(names)}, {pairs} feature pairs -> {output}")
