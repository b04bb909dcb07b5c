"""Measure sub-pixel refinement (dcstereo.refine.subpixel) on the Middlebury scenes and Motorcycle.

    python scripts/measure_subpixel.py [--data ../shared/data/middlebury]

For each Middlebury scene, the filled ``dc`` map as matched and refined by each fit:
bad-0.5 and bad-1.0 (nonocc, percent) and the mean absolute error (nonocc, pixels). For
scikit-image's Motorcycle (its calibration), the depth of the filled map against the depth
of the ground truth: median error (mm) and the pixels within 1 % and 5 %. Prints a
markdown table; the README's "Sub-pixel disparity" quotes it.
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import dcstereo
from dcstereo.evaluation.datasets import load_motorcycle, load_scene, middlebury_dir
from dcstereo.evaluation.scoring import score
from dcstereo.geometry import depth
from dcstereo.refine.subpixel import FITS, refine_subpixel

SCENES = ("tsukuba", "venus", "teddy", "cones")
SETTINGS = ("integer", *FITS)


def versions(scene):
    """Return ``{setting: (filled dc map, seconds of the refinement)}``.

    ``match(..., subpixel=fit, fill=True)``, as a user runs it: refined, then filled; the
    refinement's own time is measured on the unfilled result.
    """
    options = dict(max_disparity=scene.max_disparity, min_disparity=scene.min_disparity, fill=True)
    result = dcstereo.match(scene.left, scene.right, **options)
    out = {"integer": (result.disparity, 0.0)}
    plain = dcstereo.match(scene.left, scene.right, **{**options, "fill": False})
    for fit in FITS:
        start = time.perf_counter()
        refine_subpixel(plain, scene.left, scene.right, fit=fit)
        seconds = time.perf_counter() - start
        refined = dcstereo.match(scene.left, scene.right, **options, subpixel=fit)
        out[fit] = (refined.disparity, seconds)
    return out


def middlebury_scenes(argv, description):
    """Parse ``--data`` and load the four scenes; None (the error printed) when they fail."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument(
        "--data",
        type=Path,
        default=middlebury_dir(),
        help="folder of the Middlebury scene folders (default: %(default)s)",
    )
    args = parser.parse_args(argv)
    try:
        return [load_scene(args.data / name) for name in SCENES]
    except (OSError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return None


def main(argv=None):
    scenes = middlebury_scenes(argv, __doc__.splitlines()[0])
    if scenes is None:
        return 2
    print("| scene | map | bad-0.5 nonocc | bad-1.0 nonocc | MAE nonocc (px) | refine (ms) |")
    print("| --- | --- | ---: | ---: | ---: | ---: |")
    for scene in scenes:
        for setting, (disparity, seconds) in versions(scene).items():
            nonocc = score(disparity, scene)["nonocc"]
            print(
                f"| {scene.name} | {setting} | {nonocc['bad-0.5']:.2f} | {nonocc['bad-1.0']:.2f} "
                f"| {nonocc['mae']:.3f} | {seconds * 1000:.1f} |",
                flush=True,
            )
    moto = load_motorcycle()
    truth = depth(moto.disparity, moto.calibration)
    print()
    print("| Motorcycle depth | median error (mm) | median error (%) | within 1 % | within 5 % |")
    print("| --- | ---: | ---: | ---: | ---: |")
    for setting, (disparity, _) in versions(moto).items():
        z = depth(disparity, moto.calibration)
        both = np.isfinite(z) & np.isfinite(truth)
        error = np.abs(z[both] - truth[both])
        relative = error / truth[both]
        within = [100 * np.mean(relative <= share) for share in (0.01, 0.05)]
        print(
            f"| {setting} | {np.median(error):.1f} | {100 * np.median(relative):.2f} "
            f"| {within[0]:.1f} % | {within[1]:.1f} % |",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
