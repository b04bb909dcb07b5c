"""Write docs/RESULTS.md and its pictures from the bench library function.

    python scripts/make_results.py            # docs/RESULTS.md, docs/img/tsukuba_*.png

Runs every method of ``dcstereo.params.METHODS`` (and OpenCV's SGBM and BM when cv2 is
installed) on the four Middlebury development scenes, with default parameters and the
scene's disparity range, and tabulates the scores of the filled (dense) maps.
"""

import argparse
import dataclasses
import json
import sys
from pathlib import Path

from dcstereo import io
from dcstereo.datasets import load_scene, middlebury_dir
from dcstereo.evaluation import available_methods, bench, machine_description, mean_rows
from dcstereo.explore import PAPER_METHODS, compare_figure, compare_methods, scanline_figure
from dcstereo.explore import scanline as scanline_data
from dcstereo.params import METHODS, MatchParams

SCENES = ("tsukuba", "venus", "teddy", "cones")
SCANLINE_ROW = 150


def fmt(value, digits=2):
    return "nan" if value != value else f"{value:.{digits}f}"


def table(rows):
    head = (
        "| scene | method | bad-1.0 nonocc | bad-1.0 all | bad-1.0 disc | bad-2.0 nonocc "
        "| MAE nonocc (px) | density (raw, all) | time (ms) |"
    )
    lines = [head, "|" + " --- |" * 9]
    for row in rows:
        dense, sparse = row["dense"], row["sparse"]
        name = f"**{row['scene']}**" if row["scene"] == "mean" else row["scene"]
        lines.append(
            f"| {name} | {row['method']} | {fmt(dense['nonocc']['bad-1.0'])} "
            f"| {fmt(dense['all']['bad-1.0'])} | {fmt(dense['disc']['bad-1.0'])} "
            f"| {fmt(dense['nonocc']['bad-2.0'])} | {fmt(dense['nonocc']['mae'], 3)} "
            f"| {fmt(sparse['all']['density'], 1)} | {1000 * row['seconds']:.0f} |"
        )
    return "\n".join(lines)


README_BEGIN = "<!-- results-table: written by scripts/make_results.py -->"
README_END = "<!-- end of results-table -->"


def update_readme(path: Path, mean_table: str) -> None:
    """Replace the README's mean table (between the markers) with this run's."""
    if not path.is_file():
        return
    text = path.read_text(encoding="utf-8")
    start, end = text.find(README_BEGIN), text.find(README_END)
    if start < 0 or end < start:
        print(f"{path}: no results markers, left alone")
        return
    text = text[: start + len(README_BEGIN)] + "\n" + mean_table + "\n" + text[end:]
    with io.atomic_write(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--data",
        type=Path,
        default=middlebury_dir(),
        help="folder of the Middlebury scene folders (default: %(default)s)",
    )
    parser.add_argument(
        "--docs",
        type=Path,
        default=Path("docs"),
        help="where RESULTS.md and img/ are written (default: %(default)s)",
    )
    parser.add_argument(
        "--readme",
        type=Path,
        default=Path("README.md"),
        help="README whose mean table (between the results markers) is rewritten",
    )
    args = parser.parse_args(argv)
    images = args.docs / "img"
    try:
        scenes = [load_scene(args.data / name) for name in SCENES]
        images.mkdir(parents=True, exist_ok=True)
    except (OSError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    methods = available_methods()

    def progress(scene, method, seconds):
        print(f"{scene:>8s} {method:<12s} {1000 * seconds:7.0f} ms", flush=True)

    rows = bench(scenes, methods, progress=progress)
    means = mean_rows(rows)
    machine = machine_description()

    tsukuba = scenes[0]
    shown = list(PAPER_METHODS) + [m for m in ("redert",) if m in METHODS]
    shown += ["opencv-sgbm"] if "opencv-sgbm" in methods else []
    results = compare_methods(
        tsukuba.left, tsukuba.right, max_disparity=tsukuba.max_disparity, methods=shown
    )
    figure = compare_figure(
        tsukuba.left,
        results,
        max_disparity=tsukuba.max_disparity,
        truth=tsukuba.disparity,
        mask=tsukuba.masks["nonocc"],
    )
    io.write_rgb_png(images / "tsukuba_compare.png", figure)
    data = scanline_data(
        tsukuba.left, tsukuba.right, SCANLINE_ROW, max_disparity=tsukuba.max_disparity
    )
    io.write_rgb_png(images / "tsukuba_scanline.png", scanline_figure(data))

    defaults = {
        k: v
        for k, v in dataclasses.asdict(MatchParams(max_disparity=15)).items()
        if k not in ("max_disparity", "min_disparity", "method", "fill")
    }
    opencv = ""
    if "opencv-sgbm" in methods:
        opencv = (
            f"- OpenCV {machine['opencv']} ({machine['opencv_threads']} threads), through "
            "`dcstereo.opencv.match_opencv` with its defaults: gray input (the same luma), "
            "`blockSize` 5, `numDisparities` = range rounded up to a multiple of 16 "
            "(estimates above the scene's range dropped), SGBM `MODE_SGBM`, "
            "`P1 = 8 * 25`, `P2 = 32 * 25`, `uniquenessRatio` 10, `preFilterCap` 63; BM "
            "`uniquenessRatio` 15, `preFilterCap` 31; both `disp12MaxDiff` 1, speckle "
            "window 100, range 2.\n"
        )
    text = f"""# Results on the Middlebury development scenes

Generated by `scripts/make_results.py` (do not edit by hand) from
`dcstereo.evaluation.bench`, the function behind `dcstereo bench`.

- Scenes: {", ".join(SCENES)} from `shared/data/middlebury` (the Middlebury v2 images,
  ground truth and masks; see its README), each searched over `0..ndisp-1`.
- Scores: bad-t is the percentage of scored pixels whose error exceeds t pixels, over the
  masked pixels with known ground truth (nonocc, all, disc: the official v2 masks). They
  are computed on the **filled** maps: every method's raw map, OpenCV's included, is
  filled with the same background rule (`DisparityResult.filled()`), so every method is
  scored dense. "density (raw, all)" is the share of pixels the method itself estimated
  before filling (occlusions it detected are the rest). MAE is in pixels.
- Time: wall time of one call on the whole image, numba compilation excluded (a warm-up
  run on a few rows first), single process.
- Machine: {machine["cpu"]}, {machine["cores"]} cores, numba {machine["numba"]} with
  {machine["numba_threads"]} threads, numpy {machine["numpy"]}, Python {machine["python"]}.
- dcstereo parameters: the defaults of `MatchParams` for every method:
  `{json.dumps(defaults, default=str)}`.
{opencv}
## Every scene

{table(rows)}

## Mean over the four scenes

{table(means)}

## Tsukuba, side by side (the paper's Fig. 4 on real data)

`dcstereo compare` (left image, then one column per method: the paper's display with
occlusions white, the filled map in colour, the error map with errors over 1 px in red;
the caption gives bad-1.0 nonocc of the filled map):

![tsukuba compare](img/tsukuba_compare.png)

## Tsukuba row {SCANLINE_ROW}, the scanline view (the paper's Fig. 1 / 2)

`dcstereo scanline`: the DSI of the row, the optimal paths of dsi3, dsi5 and dc, the
feature pairs dc accepted (yellow) and the two intensity profiles:

![tsukuba scanline](img/tsukuba_scanline.png)
"""
    with io.atomic_write(args.docs / "RESULTS.md") as tmp:
        tmp.write_text(text, encoding="utf-8")
    update_readme(args.readme, table(means))
    print(table(means))
    print(f"wrote {args.docs / 'RESULTS.md'} and {images}/tsukuba_{{compare,scanline}}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
