"""``dcstereo eval``: score one disparity file against a scene folder of any layout."""

import click

from dcstereo.cli._common import one_line_errors


@click.command("eval")
@click.argument("prediction", type=click.Path(dir_okay=False))
@click.argument("scene_dir", type=click.Path(file_okay=False))
@click.option(
    "--scale",
    type=float,
    default=None,
    help="Stored value per pixel of disparity of a PNG PREDICTION: needed for an 8-bit PNG "
    "(Middlebury's own maps: 16 for tsukuba, 8 for venus, 4 for teddy and cones); 256 for a "
    "16-bit PNG by default.",
)
@click.option(
    "--gt-scale",
    type=float,
    default=None,
    help="Stored gray value per pixel of disparity of the ground truth of a 2005/2006 scene "
    "whose size is not a standard one (default: 1, 2 or 3 from the image height).",
)
@click.option(
    "--frame",
    default=None,
    help="The frame of a KITTI 2012/2015 training folder SCENE_DIR, such as 000046_10.",
)
@click.option("--json", "as_json", is_flag=True, help="Print the scores as JSON (null: no value).")
@one_line_errors
def eval_command(prediction, scene_dir, scale, gt_scale, frame, as_json):
    """Score PREDICTION (PFM, or 16-bit PNG of d * 256) against the scene in SCENE_DIR.

    Bad-pixel rates at 0.5, 1, 2 and 4 pixels, mean absolute and RMS error and density,
    for each mask of the scene (nonocc, all, and disc where the layout has it). Pixels
    without an estimate count as bad; the denominator is the masked pixels with known
    ground truth. MAE and RMS have no value when the map has no estimate in the mask.
    A v2 scene folder with some of nonocc.png, all.png and disc.png is scored on those,
    one with none on every pixel with ground truth; the output says which masks were
    scored and which not (in the JSON: "masks" and "masks_missing").

    KITTI data (a training folder with --frame, or a one-pair folder of left.png,
    right.png, a 16-bit disp_gt.png and meta.json) is also scored with KITTI's measures:
    D1 (error over 3 px and over 5 % of the truth; "d1" in the JSON) and bad-2/3/4, over
    all (disp_occ) and nonocc (disp_noc, KITTI's noc), those the data has.
    """
    from dcstereo.evaluation.scoring import (
        evaluate_file,
        mask_lines,
        render,
        scores_table,
        to_json,
    )

    result = evaluate_file(prediction, scene_dir, scale=scale, truth_scale=gt_scale, frame=frame)
    if as_json:
        click.echo(to_json(result, indent=2))
    else:
        click.echo(render(scores_table(result)), nl=False)
        for line in mask_lines(result):
            click.echo(line)
