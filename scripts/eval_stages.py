"""Score one method and its options on every development scene, indoor and outdoor.

Indoor: the 22 Middlebury development scenes (the folder of ``dcstereo.evaluation.datasets`` and
scikit-image's Motorcycle), the map filled (:meth:`~dcstereo.DisparityResult.filled`),
bad-1.0 over the ``nonocc`` mask; the groups are the four v2 scenes and the 18 others.
Outdoor: the 20 KITTI pairs of ``../shared/data/outdoor`` (``disp_gt.png``: uint16 / 256,
0 = no truth), searched over ``0 .. ndisp - 1`` of ``meta.json``, scored dense over every
pixel with truth (a pixel without an estimate counts wrong): bad-2, bad-3 and D1 (error
over 3 px and over 5 % of the true disparity)::

    python scripts/eval_stages.py
    python scripts/eval_stages.py --options "{'census_window': (7, 9)}" --json out.json
    python scripts/eval_stages.py --groups kitti --scenes kitti2012_000078_10

Each scene's line gives its scores and its seconds (one process, numba compiled once on a
few rows first); the last lines the group means.
"""

import argparse
import ast
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from dcstereo.evaluation.datasets import find_scenes, load_motorcycle, load_scene, middlebury_dir
from dcstereo.evaluation.metrics import bad_pixel_rate, d1_rate
from dcstereo.evaluation.scoring import run_method

V2 = ("tsukuba", "venus", "teddy", "cones")
#: The groups of scenes ``--groups`` takes: the Middlebury scenes, the KITTI pairs.
GROUPS = ("mb", "kitti")
OUTDOOR = Path(
    os.environ.get("DCSTEREO_OUTDOOR", Path(__file__).resolve().parents[2] / "shared/data/outdoor")
)


def kitti_scores(estimate: np.ndarray, truth: np.ndarray) -> dict:
    """bad-2, bad-3 and D1 (percent) over the pixels with truth (``truth > 0``; NaN: none), dense.

    A NaN estimate counts as wrong (:mod:`dcstereo.evaluation.metrics`).
    """
    known = truth > 0
    return {
        "bad2": bad_pixel_rate(estimate, truth, threshold=2.0, mask=known),
        "bad3": bad_pixel_rate(estimate, truth, threshold=3.0, mask=known),
        "d1": d1_rate(estimate, truth, mask=known),
    }


def kitti_pairs(root=OUTDOOR):
    """Yield ``(name, left, right, truth, max_disparity)`` for each outdoor pair.

    Read by :func:`~dcstereo.evaluation.datasets.load_scene` (the one-pair KITTI layout:
    ``truth`` NaN where there is none, ``max_disparity`` ``ndisp - 1``).
    """
    for folder in sorted(p for p in Path(root).iterdir() if (p / "meta.json").exists()):
        scene = load_scene(folder)
        yield folder.name, scene.left, scene.right, scene.disparity, scene.max_disparity


def middlebury_scenes():
    """Every Middlebury development scene and Motorcycle."""
    scenes = [load_scene(folder) for folder in find_scenes(middlebury_dir())]
    scenes.append(load_motorcycle())
    return scenes


def relit(image, gain=1.0, offset=0.0, gamma=1.0):
    """``image`` (uint8) with its values ``255 * (gain * v / 255) ** gamma + offset``, clipped."""
    if gain == 1.0 and offset == 0.0 and gamma == 1.0:
        return image
    values = 255.0 * (gain * np.asarray(image, dtype=np.float64) / 255.0) ** gamma + offset
    return np.clip(np.rint(values), 0, 255).astype(np.uint8)


def run(method, options, groups, names=None, warm=True, light=(1.0, 0.0, 1.0)):
    """Score every scene of ``groups``; return ``{name: {metric: value, "s": seconds}}``.

    ``light``: the right view's ``(gain, offset, gamma)`` change (:func:`relit`).
    """
    out = {}
    if "mb" in groups:
        for scene in middlebury_scenes():
            if names and scene.name not in names:
                continue
            if warm:
                run_method(method, scene.left[:12], scene.right[:12],
                           max_disparity=scene.max_disparity,
                           min_disparity=scene.min_disparity, **options)  # fmt: skip
                warm = False
            start = time.perf_counter()
            result = run_method(method, scene.left, relit(scene.right, *light),
                                max_disparity=scene.max_disparity,
                                min_disparity=scene.min_disparity, **options)  # fmt: skip
            seconds = time.perf_counter() - start
            filled = result.filled().disparity
            bad = bad_pixel_rate(filled, scene.disparity, threshold=1.0, mask=scene.masks["nonocc"])
            out[scene.name] = {"bad1": bad, "s": seconds}
            print(f"{scene.name:22s} bad1 {bad:6.2f}   {seconds:6.2f} s", flush=True)
    if "kitti" in groups:
        for name, left, right, truth, top in kitti_pairs():
            if names and name not in names:
                continue
            if warm:
                run_method(method, left[:12], right[:12], max_disparity=top, **options)
                warm = False
            start = time.perf_counter()
            result = run_method(method, left, relit(right, *light), max_disparity=top, **options)
            seconds = time.perf_counter() - start
            scores = kitti_scores(result.filled().disparity, truth)
            scores["s"] = seconds
            out[name] = scores
            print(
                f"{name:22s} bad2 {scores['bad2']:6.2f} bad3 {scores['bad3']:6.2f} "
                f"D1 {scores['d1']:6.2f}   {seconds:6.2f} s",
                flush=True,
            )
    return out


def group_summary(scores, reference=None) -> str:
    """The group means (and, with ``reference``, the wins over it)."""
    v2 = [v["bad1"] for n, v in scores.items() if n in V2]
    new = {n: v["bad1"] for n, v in scores.items() if "bad1" in v and n not in V2}
    kitti = {n: v for n, v in scores.items() if "d1" in v}
    lines = []
    if v2:
        lines.append(f"v2 (4)        bad1 {np.mean(v2):6.2f}")
    if new:
        line = f"newer ({len(new)})    bad1 {np.mean(list(new.values())):6.2f}"
        if reference:
            won = sum(new[n] < reference[n]["bad1"] for n in new if n in reference)
            line += f"  better than reference on {won}/{len(new)}"
        lines.append(line)
    if kitti:
        means = {m: np.mean([v[m] for v in kitti.values()]) for m in ("bad2", "bad3", "d1")}
        line = (
            f"KITTI ({len(kitti)})    bad2 {means['bad2']:6.2f} bad3 {means['bad3']:6.2f} "
            f"D1 {means['d1']:6.2f}"
        )
        if reference:
            won = sum(kitti[n]["d1"] < reference[n]["d1"] for n in kitti if n in reference)
            line += f"  D1 better on {won}/{len(kitti)}"
        lines.append(line)
    total = sum(v["s"] for v in scores.values())
    lines.append(f"seconds       {total:.1f}")
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--method", default="sgm")
    parser.add_argument("--options", default="{}", help="dict of match options")
    parser.add_argument(
        "--groups",
        default=",".join(GROUPS),
        help=f"the groups to score, comma-separated, of {', '.join(GROUPS)} (Middlebury, KITTI)",
    )
    parser.add_argument("--scenes", help="comma-separated scene names (default: all)")
    parser.add_argument("--json", help="write the scores to this file")
    parser.add_argument(
        "--light", default="1,0,1", help="the right view's gain,offset,gamma (a lighting change)"
    )
    parser.add_argument("--reference", help="a --json file to count wins against")
    args = parser.parse_args(argv)
    options = ast.literal_eval(args.options)
    names = set(args.scenes.split(",")) if args.scenes else None
    groups = args.groups.split(",")
    unknown = sorted(set(groups) - set(GROUPS))
    if unknown:
        parser.error(f"--groups: unknown group {', '.join(unknown)} (of {', '.join(GROUPS)})")
    print(f"# {args.method} {options}", flush=True)
    light = tuple(float(v) for v in args.light.split(","))
    scores = run(args.method, options, groups, names, light=light)
    reference = json.loads(Path(args.reference).read_text())["scores"] if args.reference else None
    print(group_summary(scores, reference))
    if args.json:
        Path(args.json).write_text(
            json.dumps(
                {"method": args.method, "options": repr(options), "scores": scores}, indent=1
            )
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
