"""Make the README's pictures from the project's own code.

    python scripts/make_figures.py            # writes docs/img/*.png

1. ``docs/img/tsukuba_methods.png``: the left image of Tsukuba, then block, dsi3, dsi5 and dc
   in the paper's display (histogram-equalized disparity, occlusions brightest), with their
   bad-1.0 nonocc (dense) in the caption row printed to stdout.
2. ``docs/img/motorcycle_dc.png``: scikit-image's Motorcycle: left, dc in the paper's display
   with the reliable feature pairs in red, and the filled dc map in colour.
3. ``docs/img/motorcycle_cloud.png``: the point cloud of the filled dc map
   (``dcstereo.geometry.point_cloud`` with the pair's calibration), seen from viewpoints
   turned 30 degrees to either side around the motorcycle.
4. ``docs/img/motorcycle_confidence.png``: the confidence of the sparse dc map
   (``dcstereo.refine.confidence``; bright = sure, black = none) beside its errors against the
   ground truth (``viz.error_map``: red = more than 1 px off).
5. ``docs/img/motorcycle_subpixel.png``: the point cloud of the filled dc map seen from 60
   degrees to the side, with whole-pixel disparities and with ``subpixel="equiangular"``.
6. ``docs/img/motorcycle_sgm.png``: the default method, ``sgm``, on Motorcycle: left, its
   estimates before the fill in the paper's display (occluded and mismatched pixels
   brightest), its map in colour, and its errors (red: more than 1 px off); and
   ``docs/img/motorcycle_sgm_cloud.png``, its point cloud from 30 degrees to either side.
"""

import argparse
import sys
from pathlib import Path

import numpy as np

import dcstereo
from dcstereo import io, viz
from dcstereo.evaluation.datasets import load_middlebury, load_motorcycle
from dcstereo.evaluation.metrics import bad_pixel_rate
from dcstereo.geometry import point_cloud
from dcstereo.refine.confidence import confidence
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


def render(points, colors, shape, yaw_degrees, focal):
    """Paint the points as a pinhole camera turned ``yaw_degrees`` about their centre sees them.

    The camera looks at the points' median from the origin's distance, turned about the
    vertical axis through the median; nearer points paint over farther ones (each a 2 x 2
    square), the background is white.
    """
    height, width = shape
    centre = np.median(points, axis=0)
    angle = np.radians(yaw_degrees)
    turn = np.array(
        [[np.cos(angle), 0, -np.sin(angle)], [0, 1, 0], [np.sin(angle), 0, np.cos(angle)]]
    )
    seen = (points - centre) @ turn.T + [0, 0, np.linalg.norm(centre)]
    ahead = seen[:, 2] > 1e-6
    seen, colors = seen[ahead], colors[ahead]
    u = np.rint(focal * seen[:, 0] / seen[:, 2] + (width - 1) / 2).astype(np.int64)
    v = np.rint(focal * seen[:, 1] / seen[:, 2] + (height - 1) / 2).astype(np.int64)
    picture = np.full((height, width, 3), 255, dtype=np.uint8)
    order = np.argsort(-seen[:, 2], kind="stable")  # far first: the near ones paint last
    u, v, colors = u[order], v[order], colors[order]
    for du in (0, 1):
        for dv in (0, 1):
            x, y = u + du, v + dv
            inside = (0 <= x) & (x < width) & (0 <= y) & (y < height)
            picture[y[inside], x[inside]] = colors[inside]
    return picture


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

    cloud = point_cloud(result.filled().disparity, moto.calibration, moto.left)
    views = [
        render(cloud.points, cloud.colors, moto.shape, yaw, moto.calibration.focal)
        for yaw in (-30, 30)
    ]
    io.write_rgb_png(args.out / "motorcycle_cloud.png", strip(views))
    print(f"motorcycle dc (filled): {len(cloud)} points")

    sure = confidence(result, moto.left, moto.right)
    shade = np.where(np.isfinite(sure), np.rint(255 * np.clip(sure, 0, 1)), 0).astype(np.uint8)
    errors = viz.error_map(result.disparity, moto.disparity)
    io.write_rgb_png(args.out / "motorcycle_confidence.png", strip([as_rgb(shade), errors]))

    fine = dcstereo.match(
        moto.left, moto.right, max_disparity=64, method="dc", subpixel="equiangular", fill=True
    )
    views = []
    for disparity in (result.filled().disparity, fine.disparity):
        cloud = point_cloud(disparity, moto.calibration, moto.left)
        views.append(render(cloud.points, cloud.colors, moto.shape, 60, moto.calibration.focal))
    io.write_rgb_png(args.out / "motorcycle_subpixel.png", strip(views))

    sgm = dcstereo.match(moto.left, moto.right, max_disparity=64)  # the default method
    raw = sgm.unfilled()
    missing = ~np.isfinite(raw.disparity)
    panels = [
        gray_rgb(moto.left),
        viz.paper_display(raw.disparity, missing),
        viz.colorize(sgm.disparity),
        viz.error_map(sgm.disparity, moto.disparity),
    ]
    io.write_rgb_png(args.out / "motorcycle_sgm.png", strip(panels))
    cloud = point_cloud(sgm.disparity, moto.calibration, moto.left)
    views = [
        render(cloud.points, cloud.colors, moto.shape, yaw, moto.calibration.focal)
        for yaw in (-30, 30)
    ]
    io.write_rgb_png(args.out / "motorcycle_sgm_cloud.png", strip(views))
    bad = bad_pixel_rate(sgm.disparity, moto.disparity, mask=moto.masks["nonocc"])
    print(f"motorcycle sgm bad-1.0 nonocc {bad:5.2f} %, {len(cloud)} points")
    print(
        f"wrote {args.out}/tsukuba_methods.png, motorcycle_dc.png, motorcycle_cloud.png, "
        "motorcycle_confidence.png, motorcycle_subpixel.png, motorcycle_sgm.png and "
        "motorcycle_sgm_cloud.png"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
