"""Score ``sgm`` settings on every development scene, beside OpenCV's SGBM.

Each run is ``dcstereo.match(left, right, method="sgm", **options)`` on every scene under
the Middlebury folder (any layout) and on scikit-image's Motorcycle, the map filled with
:meth:`~dcstereo.DisparityResult.filled` (the project's protocol; ``sgm`` fills its own),
scored by bad-1.0 over the ``nonocc`` mask. The table gives the mean of the four v2 scenes
(tsukuba, venus, teddy, cones), the mean of the others (the 2005/2006 and 2014 scenes and
Motorcycle), how many of those beat OpenCV's ``MODE_HH``, and every scene::

    python scripts/tune_sgm.py --opencv
    python scripts/tune_sgm.py --grid "{'p1': [30, 40, 50], 'p2': [200, 240]}"
    python scripts/tune_sgm.py --grid "{'paths': [4, 8]}" --scenes teddy,Adirondack

Every combination of the grid's values is one row (other options at their defaults).
"""

import argparse
import ast
import itertools
import sys
import time

import numpy as np

from dcstereo.evaluation.datasets import find_scenes, load_motorcycle, load_scene, middlebury_dir
from dcstereo.evaluation.metrics import bad_pixel_rate, mean_abs_error
from dcstereo.evaluation.scoring import run_scene

V2 = ("tsukuba", "venus", "teddy", "cones")


def load_scenes(names=None):
    """Every development scene (and Motorcycle), or those named."""
    scenes = [load_scene(folder) for folder in find_scenes(middlebury_dir())]
    try:
        scenes.append(load_motorcycle())
    except ImportError:  # scikit-image missing
        pass
    if names:
        scenes = [s for s in scenes if s.name in names]
    return scenes


def score_run(scenes, method, options, extra=None):
    """bad-1.0 nonocc of the filled map per scene, and the seconds taken.

    ``extra``: a dict that receives each scene's bad-0.5 and mean absolute error (nonocc).
    """
    scores = {}
    start = time.perf_counter()
    for scene in scenes:
        filled = run_scene(method, scene, **options).filled().disparity
        mask = scene.masks["nonocc"]
        scores[scene.name] = bad_pixel_rate(filled, scene.disparity, threshold=1.0, mask=mask)
        if extra is not None:
            extra[scene.name] = (
                bad_pixel_rate(filled, scene.disparity, threshold=0.5, mask=mask),
                mean_abs_error(filled, scene.disparity, mask=mask),
            )
    return scores, time.perf_counter() - start


def summary(label, scores, reference=None, extra=None):
    """One line: the two group means, the wins over ``reference``, then every scene.

    With ``extra`` (from :func:`score_run`): the groups' bad-0.5 and mean error too.
    """
    v2 = [scores[n] for n in V2 if n in scores]
    new = [v for n, v in scores.items() if n not in V2]
    more = ""
    if extra:
        groups = ([n for n in extra if n in V2], [n for n in extra if n not in V2])
        more = "".join(
            f"  [{name} b0.5 {np.mean([extra[n][0] for n in names]):5.2f} "
            f"mae {np.mean([extra[n][1] for n in names]):.3f}]"
            for name, names in zip(("v2", "new"), groups, strict=True)
            if names
        )
    wins = ""
    if reference is not None:
        won = sum(scores[n] < reference[n] for n in scores if n not in V2)
        wins = f"  beats HH {won}/{len(new)}"
    means = f"v2 {np.mean(v2):5.2f}  new {np.mean(new):5.2f}" if v2 and new else ""
    scenes = " ".join(f"{n[:6]}={v:.1f}" for n, v in scores.items())
    return f"{label:44s} {means}{wins}{more}  {scenes}"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grid", default="{}", help="dict of option -> list of values")
    parser.add_argument("--method", default="sgm")
    parser.add_argument("--scenes", help="comma-separated scene names (default: all)")
    parser.add_argument("--opencv", action="store_true", help="also OpenCV SGBM and MODE_HH")
    parser.add_argument("--more", action="store_true", help="also bad-0.5 and the mean error")
    args = parser.parse_args(argv)
    scenes = load_scenes(args.scenes.split(",") if args.scenes else None)
    grid = ast.literal_eval(args.grid)
    reference = None
    if args.opencv:
        for name in ("opencv-sgbm", "opencv-hh"):
            extra = {} if args.more else None
            scores, seconds = score_run(scenes, name, {}, extra)
            print(summary(f"{name} ({seconds:.0f} s)", scores, extra=extra), flush=True)
            reference = scores if name == "opencv-hh" else reference
    names = list(grid)
    for values in itertools.product(*(grid[n] for n in names)):
        options = dict(zip(names, values, strict=True))
        extra = {} if args.more else None
        scores, seconds = score_run(scenes, args.method, options, extra)
        print(summary(f"{options} ({seconds:.0f} s)", scores, reference, extra), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
