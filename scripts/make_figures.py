"""Make the README's pictures from the project's own code.

    python scripts/make_figures.py            # writes docs/img/*.png

1. ``docs/img/tsukuba_methods.png``: the left image of Tsukuba, then block, dsi3, dsi5 and dc
   in the paper's display (histogram-equalized disparity, occlusions brightest), with their
   bad-1.0 nonocc (dense) in the caption row printed to stdout.
2. ``docs/img/motorcycle_dc.png``: scikit-image's Motorcycle: left, dc in the paper's display
   with the reliable feature pairs in red, and the filled dc map in colour.
"""

import argparse
import sys
from pathlib import Path

import numpy as np

import dcstereo
from dcstereo import io, viz
from dcstereo.datasets import load_middlebury, load_motorcycle
from dcstereo.metrics import bad_pixel_rate
from dcstereo.signal import intensity


def gray_rgb(image):
    value = np.clip(np.rint(intensity(image)), 0, 255).astype(np.uint8)
    return np.stack([value] * 3, axis=-1)


def as_rgb(picture):
    return picture if picture.ndim == 3 else np.stack([picture] * 3, axis=-1)


def strip(panels, gap=4):
    height = panels[0].shape[0]
    spacer = np.full((height, gap, 3), 255, dtype=np.uint8)
    parts = []
    for panel in panels:
        parts += [as_rgb(panel), spacer]
    return np.concatenate(parts[:-1], axis=1)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("docs/img"),
        help="folder for the PNGs (default: %(default)s)",
    )
    args = parser.parse_args(argv)
    try:
        args.out.mkdir(parents=True, exist_ok=True)
        scene = load_middlebury("tsukuba")
        moto = load_motorcycle()
    except (ImportError, OSError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2

    panels = [gray_rgb(scene.left)]
    for method in ("block", "dsi3", "dsi5", "dc"):
        result = dcstereo.match(
            scene.left, scene.right, max_disparity=scene.max_disparity, method=method
        )
        bad = bad_pixel_rate(result.filled().disparity, scene.disparity, mask=scene.masks["nonocc"])
        print(f"tsukuba {method:6s} bad-1.0 nonocc (dense) {bad:5.2f} %")
        panels.append(viz.paper_display(result.disparity, result.occluded))
    io.write_rgb_png(args.out / "tsukuba_methods.png", strip(panels))

    result = dcstereo.match(moto.left, moto.right, max_disparity=64, method="dc")
    paper = viz.paper_display(result.disparity, result.occluded)
    marked = viz.draw_points(paper, result.features[:, 1], result.features[:, 0], radius=0)
    color = viz.colorize(result.filled().disparity)
    io.write_rgb_png(args.out / "motorcycle_dc.png", strip([gray_rgb(moto.left), marked, color]))
    print(f"wrote {args.out}/tsukuba_methods.png and {args.out}/motorcycle_dc.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
