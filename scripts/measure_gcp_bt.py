"""Measure ``dsi3-gcp`` and the Birchfield-Tomasi cost on the Middlebury dev scenes.

Usage::

    python scripts/measure_gcp_bt.py table   # the README table: methods x costs x scenes
    python scripts/measure_gcp_bt.py sweep   # dsi3-gcp defaults: uniqueness x variance floor

Scores are bad-1.0 (%) of the *filled* maps in the ``nonocc``, ``all`` and ``disc`` masks
(:func:`dcstereo.evaluation.metrics.bad_pixel_rate`); times are the wall time of one call after a
warm-up call (compilation excluded).
"""

import argparse
import sys
import time

import numpy as np

import dcstereo
from dcstereo.evaluation.datasets import list_middlebury, load_middlebury, middlebury_dir
from dcstereo.evaluation.metrics import bad_pixel_rate

MASKS = ("nonocc", "all", "disc")


def run(scene, method, **options):
    """Match one scene; return (filled result, seconds)."""
    kwargs = dict(
        max_disparity=scene.max_disparity, min_disparity=scene.min_disparity, method=method
    )
    dcstereo.match(scene.left[:12], scene.right[:12], **kwargs, **options)  # compile
    start = time.perf_counter()
    result = dcstereo.match(scene.left, scene.right, **kwargs, **options)
    return result.filled(), time.perf_counter() - start


def scores(scene, disparity):
    """bad-1.0 % in each mask."""
    return [
        bad_pixel_rate(disparity, scene.disparity, mask=scene.masks[m], threshold=1.0)
        for m in MASKS
    ]


def table(scenes):
    """Print the markdown table of the README subsection and the means."""
    methods = ("dsi3", "dsi3-gcp", "redert", "dsi5", "dc")
    print("| scene | method | cost | nonocc | all | disc | GCPs/row | time (ms) |")
    print("| --- | --- | --- | ---: | ---: | ---: | ---: | ---: |")
    means = {}
    for scene in scenes:
        for method in methods:
            for cost in ("sad", "bt"):
                if method == "redert" and cost == "bt":
                    continue
                result, seconds = run(scene, method, cost=cost)
                row = scores(scene, result.disparity)
                per_row = "-"
                if method == "dsi3-gcp":
                    per_row = f"{len(result.features) / scene.shape[0]:.1f}"
                means.setdefault((method, cost), []).append(row + [seconds])
                print(
                    f"| {scene.name} | {method} | {cost} | "
                    + " | ".join(f"{v:.2f}" for v in row)
                    + f" | {per_row} | {seconds * 1000:.0f} |",
                    flush=True,
                )
    for (method, cost), rows in means.items():
        mean = np.mean(rows, axis=0)
        print(
            f"| mean | {method} | {cost} | "
            + " | ".join(f"{v:.2f}" for v in mean[:3])
            + f" | | {mean[3] * 1000:.0f} |"
        )


def sweep(scenes):
    """Mean bad-1.0 of dsi3-gcp (sad) over a grid of the two GCP parameters."""
    print("uniqueness floor  nonocc  all  disc  GCPs/row")
    for cost in ("sad", "bt"):
        for uniqueness in (1.5, 2.0, 3.0, 4.0):
            for floor in (25.0, 100.0, 400.0):
                rows = []
                count = 0.0
                for scene in scenes:
                    result, _ = run(
                        scene,
                        "dsi3-gcp",
                        cost=cost,
                        gcp_uniqueness=uniqueness,
                        gcp_variance_floor=floor,
                    )
                    rows.append(scores(scene, result.disparity))
                    count += len(result.features) / scene.shape[0] / len(scenes)
                mean = np.mean(rows, axis=0)
                print(
                    f"{cost} {uniqueness:4.1f} {floor:6.0f}  "
                    + "  ".join(f"{v:6.2f}" for v in mean)
                    + f"  {count:6.1f}",
                    flush=True,
                )


def main(argv=None):
    """Run the mode named on the command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "mode",
        nargs="?",
        default="table",
        choices=("table", "sweep"),
        help="table: methods x costs x scenes (the README table); sweep: dsi3-gcp's "
        "uniqueness x variance floor (default: table)",
    )
    args = parser.parse_args(argv)
    names = list_middlebury()
    if not names:
        print(
            f"error: no Middlebury scenes found at {middlebury_dir()}; set DCSTEREO_DATA",
            file=sys.stderr,
        )
        return 2
    scenes = [load_middlebury(name) for name in names]
    order = {"tsukuba": 0, "venus": 1, "teddy": 2, "cones": 3}
    scenes.sort(key=lambda s: order.get(s.name, 9))
    if args.mode == "sweep":
        sweep(scenes)
    else:
        table(scenes)
    return 0


if __name__ == "__main__":
    sys.exit(main())
