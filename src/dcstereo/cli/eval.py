"""``dcstereo eval``: score one disparity file against a scene folder of any layout."""

import json

import click

from ._common import one_line_errors


@click.command("eval")
@click.argument("prediction", type=click.Path(dir_okay=False))
@click.argument("scene_dir", type=click.Path(file_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Print the scores as JSON.")
@one_line_errors
def eval_command(prediction, scene_dir, as_json):
    """Score PREDICTION (PFM, or 16-bit PNG of d * 256) against the scene in SCENE_DIR.

    Bad-pixel rates at 0.5, 1, 2 and 4 pixels, mean absolute and RMS error and density,
    for each mask of the scene (nonocc, all, and disc where the layout has it). Pixels
    without an estimate count as bad; the denominator is the masked pixels with known
    ground truth.
    """
    from ..evaluation import evaluate_file, render, scores_table

    result = evaluate_file(prediction, scene_dir)
    if as_json:
        click.echo(json.dumps(result, indent=2))
    else:
        click.echo(render(scores_table(result)), nl=False)
