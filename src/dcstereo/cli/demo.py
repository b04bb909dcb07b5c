"""``dcstereo demo``: the main job on the embedded Middlebury 2014 Motorcycle pair."""

import time

import click
import numpy as np

from dcstereo.cli._common import (
    compile_watch,
    describe,
    matching_options,
    one_line_errors,
    output_folder,
    set_threads,
    staged_outputs,
)


@click.command()
@click.option(
    "--output",
    "-o",
    type=click.Path(file_okay=False),
    default="demo-output",
    show_default=True,
    help="Folder for the outputs (created if missing).",
)
@click.option(
    "--max-disparity",
    type=int,
    default=64,
    show_default=True,
    help="Largest disparity searched (the ground truth spans about 7..60).",
)
@matching_options
@one_line_errors
def demo(output, max_disparity, match_options, threads):
    """Run dcstereo on scikit-image's Middlebury 2014 Motorcycle pair and score it.

    Writes disparity.pfm, disparity.png (16-bit), occlusion.png, preview.png (the
    paper's display), preview_color.png, depth.pfm and cloud.ply (the coloured 3-D
    points, with the calibration scikit-image gives for the pair), confidence.pfm and,
    for the dc methods, features.csv and features.png (the pairs in red) into OUTPUT, and
    prints the bad-pixel rates, the depth error against the ground truth and how the
    confidence ranks the pixels.
    """
    from dcstereo import io, match
    from dcstereo.evaluation.datasets import load_motorcycle
    from dcstereo.evaluation.metrics import bad_pixel_rate, density
    from dcstereo.geometry import depth, point_cloud
    from dcstereo.refine.confidence import confidence
    from dcstereo.viz import draw_points, preview

    set_threads(threads)
    folder = output_folder(output)
    scene = load_motorcycle()
    options = dict(match_options, max_disparity=max_disparity)
    # compile (cached on disk after the first run: announced when it happens); it also
    # refuses bad options before the folder is made
    with compile_watch():
        match(scene.left, scene.right, **options)
    folder.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    final = match(scene.left, scene.right, **options)  # filled where the method fills
    seconds = time.perf_counter() - start
    result = final.unfilled()  # the estimates the method made itself
    dense = final.filled()

    with staged_outputs() as write:
        write(io.write_disparity, folder / "disparity.pfm", final.disparity)
        write(io.write_disparity, folder / "disparity.png", final.disparity)
        write(io.write_mask_png, folder / "occlusion.png", result.occluded)
        picture = preview(result.disparity, result.occluded, style="paper")
        write(io.write_rgb_png, folder / "preview.png", picture)
        if result.features is not None and len(result.features):
            write(io.write_features_csv, folder / "features.csv", result.features)
            marked = draw_points(picture, result.features[:, 1], result.features[:, 0], radius=0)
            write(io.write_rgb_png, folder / "features.png", marked)
        write(
            io.write_rgb_png, folder / "preview_color.png", preview(dense.disparity, style="color")
        )
        write(io.write_pfm, folder / "depth.pfm", depth(final.disparity, scene.calibration))
        cloud = point_cloud(final.disparity, scene.calibration, scene.left)
        write(io.write_ply, folder / "cloud.ply", cloud.points, cloud.colors)
        sure = confidence(final, scene.left, scene.right)
        write(io.write_pfm, folder / "confidence.pfm", sure)

    height, width = scene.shape
    truth, known = scene.disparity, scene.masks["all"]
    evaluations = height * width * (max_disparity + 1)
    click.echo(
        f"Middlebury 2014 Motorcycle (scikit-image), {width}x{height}, "
        f"disparities 0..{max_disparity}"
    )
    click.echo(
        describe(final.params)
        + f": {seconds * 1000:.0f} ms ({evaluations / seconds / 1e6:.0f} M disparity "
        "evaluations/s)"
    )
    for name, estimate in (("sparse (before any fill)", result), ("dense (filled)", dense)):
        d = estimate.disparity
        bad1 = bad_pixel_rate(d, truth, mask=known)
        bad2 = bad_pixel_rate(d, truth, mask=known, threshold=2.0)
        click.echo(
            f"  {name:31s} bad-1.0 {bad1:5.2f} %  bad-2.0 {bad2:5.2f} %"
            f"  density {density(d, truth, mask=known):5.1f} %"
        )
    truth_depth = depth(truth, scene.calibration)
    dense_depth = depth(dense.disparity, scene.calibration)
    both = known & np.isfinite(truth_depth) & np.isfinite(dense_depth)
    error = np.abs(dense_depth[both] - truth_depth[both])
    relative = error / truth_depth[both]
    click.echo(
        f"  depth of the dense map: median error {np.median(error):.1f} mm "
        f"({100 * np.median(relative):.2f} %), {100 * np.mean(relative <= 0.05):.1f} % of "
        "pixels within 5 %"
    )
    scored = known & np.isfinite(result.disparity) & np.isfinite(sure)
    bad = np.abs(result.disparity - truth)[scored] > 1.0
    surer = sure[scored] >= np.median(sure[scored])
    click.echo(
        f"  confidence: the surer half of the estimates bad-1.0 {100 * bad[surer].mean():.2f} %, "
        f"the other half {100 * bad[~surer].mean():.2f} %"
    )
    if result.features is not None:
        count = len(result.features)
        click.echo(f"  {count} reliable feature pairs ({count / height:.1f} per row)")
    click.echo(f"outputs in {folder}/: " + ", ".join(sorted(p.name for p in folder.iterdir())))
