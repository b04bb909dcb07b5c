"""``dcstereo bench``: run methods over every scene under a folder and tabulate the scores."""

import math

import click

from dcstereo.cli._common import (
    add_method_options,
    check_method_options,
    check_output_paths,
    compile_watch,
    median_option,
    one_line_errors,
    set_threads,
)
from dcstereo.evaluation.metrics import DEFAULT_THRESHOLDS
from dcstereo.params import SUBPIXEL_FITS, check_median


@click.command()
@click.argument("data_dir", type=click.Path(file_okay=False))
@click.option(
    "--methods",
    default="all",
    show_default=True,
    help="Comma-separated methods (dcstereo's, opencv-sgbm, opencv-bm); all: every "
    "dcstereo method, and OpenCV's when it is installed.",
)
@click.option(
    "--window",
    type=int,
    default=None,
    help="Odd window side, for every method (default: each method's own; OpenCV's block 5).",
)
@click.option(
    "--subpixel",
    type=click.Choice(SUBPIXEL_FITS),
    default=None,
    help="Refine dcstereo's whole-pixel disparities by this fit (see run --subpixel; "
    "OpenCV's are sub-pixel already). Default: off. It and --median reach dcstereo's "
    "methods only.",
)
@median_option
@click.option(
    "--threshold",
    type=float,
    default=1.0,
    show_default=True,
    help="Bad-pixel threshold of the table, in pixels (the JSON has 0.5, 1, 2, 4 and it).",
)
@click.option(
    "--json",
    "json_out",
    type=click.Path(dir_okay=False),
    default=None,
    help="Also write every score (sparse and dense, all masks) to this JSON file.",
)
@click.option(
    "--gt-scale",
    type=float,
    default=None,
    help="Stored gray value per pixel of disparity of the ground truth of the 2005/2006 "
    "scenes, for those whose size is not a standard one (default: 1, 2 or 3 from the image "
    "height; the other layouts give their own).",
)
@click.option("--threads", type=int, default=None, help="Number of threads (default: all).")
@click.option("--quiet", "-q", is_flag=True, help="Print only the table.")
@add_method_options
@one_line_errors
def bench(
    data_dir, methods, window, subpixel, median, threshold, json_out, gt_scale, threads, quiet,
    method_options,
):  # fmt: skip
    """Run METHODS on every scene folder under DATA_DIR and print a table.

    Scene folders of any layout are found at any depth (v2, 2005/2006, 2014); all are
    loaded before any method runs, and one that cannot be read stops the bench. The table
    gives bad-1.0 (or --threshold) (%) of the filled (dense) maps in the nonocc, all and
    disc masks and their mean absolute error over nonocc, the density of the raw map and
    the time per run, then the mean of each method. A method's own options (--ser-min
    and the others of run) reach the methods that read them. A scene without one of the
    masks (a v2 folder with only some of nonocc.png, all.png, disc.png; the other layouts
    have no disc mask) shows - in its cells, the mean is over the scenes that have the
    mask, and a line after the table names them (the JSON: each row's "masks_missing").
    KITTI training folders (every frame with ground truth) and one-pair KITTI folders
    get a second table: D1, bad-2.0 and bad-3.0 (%) over nonocc (KITTI's noc) and all.
    """
    from dcstereo import io
    from dcstereo.evaluation.scoring import (
        bench_folder,
        bench_table,
        json_rows,
        machine_description,
        missing_mask_lines,
        parse_methods,
        render,
        to_json,
    )

    check_output_paths(json_out)
    names = parse_methods(methods)
    if not (math.isfinite(threshold) and threshold > 0):
        raise ValueError(f"--threshold must be a positive number of pixels, got {threshold:g}")
    thresholds = sorted({*DEFAULT_THRESHOLDS, threshold})
    if median is not None:
        check_median(median, "--median")
    check_method_options(method_options, names)
    match_options = {"subpixel": subpixel}
    if median is not None:
        match_options["median"] = median
    match_options.update(method_options)
    set_threads(threads)

    def progress(scene, method, seconds):
        if not quiet:
            click.echo(f"{scene:>14s} {method:<12s} {1000 * seconds:8.0f} ms", err=True)

    with compile_watch(quiet):  # each method's first run on a machine compiles it
        rows = bench_folder(
            data_dir,
            names,
            options={} if window is None else {"window": window},
            match_options=match_options,
            thresholds=thresholds,
            progress=progress,
            truth_scale=gt_scale,
        )
    table = bench_table(rows, title=f"bench {data_dir}", threshold=threshold)
    click.echo(render(table), nl=False)
    kitti_rows = [r for r in rows if any("d1" in s for s in r["dense"].values())]
    if kitti_rows:  # KITTI's measures, for the KITTI scenes
        from dcstereo.evaluation.kitti import kitti_table

        click.echo(render(kitti_table(kitti_rows, title="KITTI's measures (dense)")), nl=False)
    if not quiet:
        for line in missing_mask_lines(rows):
            click.echo(line)
    if json_out is not None:
        payload = {
            "machine": machine_description(),
            "window": window,
            "match_options": match_options,
            "rows": json_rows(rows),
        }
        with io.atomic_write(json_out) as tmp:
            tmp.write_text(to_json(payload, indent=1), encoding="utf-8")
