"""Write docs/RESULTS.md, the README's headline table and the Tsukuba figures.

    python scripts/make_results.py            # docs/RESULTS.md, docs/img/tsukuba_*.png, README

Runs dcstereo's methods and OpenCV's SGBM (``MODE_SGBM`` and ``MODE_HH``, on the colour
images) and BM on every development scene (the Middlebury folders of any layout under
``shared/data/middlebury``, and scikit-image's Motorcycle) with default parameters and each
scene's disparity range, through :func:`dcstereo.evaluation.bench`, and tabulates the scores
of the filled (dense) maps: per group of scenes (the four Middlebury v2 scenes; the 2005/2006
and 2014 scenes with Motorcycle) and per scene. ``redert`` and ``dc-linear`` run on the v2
scenes only (they are slow, or far behind, on the larger ones).
"""

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

from dcstereo import io
from dcstereo.evaluation.datasets import find_scenes, load_motorcycle, load_scene, middlebury_dir
from dcstereo.evaluation.scoring import bench, machine_description, opencv_available
from dcstereo.params import DEFAULT_METHOD, FIXED_OPTIONS, METHODS, MatchParams
from dcstereo.viz.explore import PAPER_METHODS, compare_figure, compare_methods, scanline_figure
from dcstereo.viz.explore import scanline as scanline_data

#: The four Middlebury v2 scenes (2001, 2003), the paper's era.
V2 = ("tsukuba", "venus", "teddy", "cones")
#: The methods run on every scene, then those run on the v2 scenes only.
METHODS_ALL = ("sgm", "sgm-accurate", "dc", "dsi5", "dsi3", "dsi3-gcp", "block")
METHODS_V2 = ("dc-linear", "redert")
OPENCV = ("opencv-sgbm", "opencv-hh", "opencv-bm")
#: The OpenCV row the targets of issue 8 compare with.
REFERENCE = "opencv-hh"
SCANLINE_ROW = 150


def fmt(value, digits=2):
    return "nan" if value != value else f"{value:.{digits}f}"


def group_of(name):
    return "v2" if name in V2 else "new"


GROUP_TITLES = {
    "v2": "Middlebury v2 (tsukuba, venus, teddy, cones)",
    "new": "2005/2006 and 2014 scenes, and Motorcycle",
}


def dense(row, key, mask="nonocc"):
    return row["dense"].get(mask, {}).get(key, float("nan"))


def group_table(rows, methods):
    """Means per group: bad-0.5, bad-1.0, bad-2.0 and MAE (nonocc), bad-1.0 all, time."""
    lines = [
        "| scenes | method | bad-1.0 nonocc | bad-0.5 nonocc | bad-2.0 nonocc | MAE nonocc (px) "
        f"| bad-1.0 all | better than {REFERENCE} | time (ms) |",
        "|" + " --- |" * 9,
    ]
    reference = {r["scene"]: dense(r, "bad-1.0") for r in rows if r["method"] == REFERENCE}
    for group in ("v2", "new"):
        for method in methods:
            mine = [r for r in rows if r["method"] == method and group_of(r["scene"]) == group]
            if not mine:
                continue
            wins = sum(dense(r, "bad-1.0") < reference.get(r["scene"], np.inf) for r in mine)
            better = "" if method == REFERENCE or not reference else f"{wins} of {len(mine)}"
            name = f"**{method}**" if method == DEFAULT_METHOD else method
            lines.append(
                f"| {group} ({len(mine)}) | {name} | "
                + " | ".join(
                    fmt(np.mean([dense(r, key) for r in mine]), 3 if key == "mae" else 2)
                    for key in ("bad-1.0", "bad-0.5", "bad-2.0", "mae")
                )
                + f" | {fmt(np.mean([dense(r, 'bad-1.0', 'all') for r in mine]))} | {better} "
                f"| {1000 * np.mean([r['seconds'] for r in mine]):.0f} |"
            )
    return "\n".join(lines)


def scene_table(rows, methods, key="bad-1.0"):
    """One row per scene, one column per method: ``key`` over nonocc of the dense map."""
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    by = {(r["scene"], r["method"]): r for r in rows}
    lines = [
        "| scene | " + " | ".join(methods) + " |",
        "|" + " --- |" * (len(methods) + 1),
    ]
    for scene in sorted(scenes, key=lambda s: (group_of(s) != "v2", s.lower())):
        cells = []
        best = min(dense(by[(scene, m)], key) for m in methods if (scene, m) in by)
        for method in methods:
            row = by.get((scene, method))
            value = fmt(dense(row, key)) if row else "-"
            cells.append(f"**{value}**" if row and dense(row, key) == best else value)
        lines.append(f"| {scene} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


README_BEGIN = "<!-- results-table: written by scripts/make_results.py -->"
README_END = "<!-- end of results-table -->"


def readme_table(rows):
    """The README's headline: bad-1.0 nonocc per group, the default beside OpenCV and dc."""
    methods = [m for m in (DEFAULT_METHOD, "sgm-accurate", "dc", "opencv-sgbm", REFERENCE) if any(
        r["method"] == m for r in rows)]  # fmt: skip
    reference = {r["scene"]: dense(r, "bad-1.0") for r in rows if r["method"] == REFERENCE}
    lines = [
        "| method | v2 scenes (4) | 2005/2006, 2014 and Motorcycle (18) | bad-0.5, same 18 "
        "| better than SGBM `MODE_HH` on (of the 18) |",
        "| --- | --- | --- | --- | --- |",
    ]
    for method in methods:
        mine = [r for r in rows if r["method"] == method]
        v2 = [dense(r, "bad-1.0") for r in mine if group_of(r["scene"]) == "v2"]
        new = [r for r in mine if group_of(r["scene"]) == "new"]
        wins = sum(dense(r, "bad-1.0") < reference.get(r["scene"], np.inf) for r in new)
        label = {"opencv-sgbm": "OpenCV SGBM `MODE_SGBM`", "opencv-hh": "OpenCV SGBM `MODE_HH`"}
        name = label.get(method, f"`{method}`")
        name = f"**{name}** (default)" if method == DEFAULT_METHOD else name
        lines.append(
            f"| {name} | {fmt(np.mean(v2))} | {fmt(np.mean([dense(r, 'bad-1.0') for r in new]))} "
            f"| {fmt(np.mean([dense(r, 'bad-0.5') for r in new]))} "
            f"| {'-' if method == REFERENCE else f'{wins} of {len(new)}'} |"
        )
    return "\n".join(lines)


def update_readme(path: Path, table: str) -> None:
    """Replace the README's table (between the markers) with this run's."""
    if not path.is_file():
        return
    text = path.read_text(encoding="utf-8")
    start, end = text.find(README_BEGIN), text.find(README_END)
    if start < 0 or end < start:
        print(f"{path}: no results markers, left alone")
        return
    text = text[: start + len(README_BEGIN)] + "\n" + table + "\n" + text[end:]
    with io.atomic_write(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--data", type=Path, default=middlebury_dir(),
        help="folder of the Middlebury scene folders (default: %(default)s)",
    )  # fmt: skip
    parser.add_argument(
        "--docs", type=Path, default=Path("docs"),
        help="where RESULTS.md and img/ are written (default: %(default)s)",
    )  # fmt: skip
    parser.add_argument(
        "--readme", type=Path, default=Path("README.md"),
        help="README whose table (between the results markers) is rewritten",
    )  # fmt: skip
    parser.add_argument("--json", type=Path, help="also write every row (scores, times) here")
    args = parser.parse_args(argv)
    images = args.docs / "img"
    try:
        scenes = [load_scene(folder) for folder in find_scenes(args.data)]
        if not scenes:
            raise ValueError(f"no scene under {args.data}")
        scenes.append(load_motorcycle())
        images.mkdir(parents=True, exist_ok=True)
    except (OSError, ValueError, ImportError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    opencv = list(OPENCV) if opencv_available() else []

    def progress(scene, method, seconds):
        print(f"{scene:>12s} {method:<12s} {1000 * seconds:7.0f} ms", flush=True)

    rows = bench(scenes, [*METHODS_ALL, *opencv], progress=progress)
    v2_scenes = [s for s in scenes if s.name in V2]
    rows += bench(v2_scenes, list(METHODS_V2), progress=progress)
    machine = machine_description()
    methods = [*METHODS_ALL, *METHODS_V2, *opencv]

    tsukuba = next(s for s in scenes if s.name == "tsukuba")
    shown = ["sgm", *PAPER_METHODS] + (["opencv-hh"] if opencv else [])
    results = compare_methods(
        tsukuba.left, tsukuba.right, max_disparity=tsukuba.max_disparity, methods=shown
    )
    figure = compare_figure(tsukuba.left, results, max_disparity=tsukuba.max_disparity,
                            truth=tsukuba.disparity, mask=tsukuba.masks["nonocc"])  # fmt: skip
    io.write_rgb_png(images / "tsukuba_compare.png", figure)
    data = scanline_data(tsukuba.left, tsukuba.right, SCANLINE_ROW,
                         max_disparity=tsukuba.max_disparity)  # fmt: skip
    io.write_rgb_png(images / "tsukuba_scanline.png", scanline_figure(data))

    defaults = {
        k: v
        for k, v in dataclasses.asdict(MatchParams(max_disparity=15)).items()
        if k
        in (
            "window",
            "cost",
            "census_window",
            "ad_truncation",
            "p1",
            "p2",
            "p2_gradient",
            "paths",
            "lr_tolerance",
            "subpixel",
            "fill",
            "median",
        )  # fmt: skip
    }
    opencv_text = ""
    if opencv:
        opencv_text = (
            f"- OpenCV {machine['opencv']} ({machine['opencv_threads']} threads), through "
            "`dcstereo.compat.opencv.match_opencv`: the colour images (BGR), `blockSize` 5, "
            "`numDisparities` = the range rounded up to a multiple of 16 (estimates above the "
            "scene's range dropped), `P1 = 8 * 3 * 25`, `P2 = 32 * 3 * 25`, `uniquenessRatio` "
            "10, `preFilterCap` 63, `disp12MaxDiff` 1, speckle window 100, range 2; "
            "`opencv-sgbm` is `MODE_SGBM` (OpenCV's default, 5 directions in one pass), "
            "`opencv-hh` `MODE_HH` (8 directions); `opencv-bm` is StereoBM on the luma.\n"
        )
    masks = (
        "nonocc: the official masks of the v2 and 2014 scenes; for the 2005/2006 scenes, "
        "which have none, the left-right cross-check of the two ground-truth maps (tolerance "
        "1 px, `dcstereo.evaluation.datasets`); all: every pixel with ground truth"
    )
    text = f"""# Results on the Middlebury development scenes

Generated by `scripts/make_results.py` (do not edit by hand) from
`dcstereo.evaluation.bench`, the function behind `dcstereo bench`.

- Scenes: the {len(scenes) - 1} scenes of `shared/data/middlebury` (the four Middlebury v2
  scenes; 12 of 2005/2006 at third size; 5 of the 2014 training set at quarter size; see its
  README) and scikit-image's 2014 Motorcycle, each searched over its own range
  (`0..ndisp - 1`, or up to its largest ground-truth disparity).
- Scores: bad-t is the percentage of scored pixels whose error exceeds t pixels; MAE the mean
  absolute error (px). Masks: {masks}. Every method's map, OpenCV's included, is scored
  **dense**: filled with the same background rule (`DisparityResult.filled()`; `sgm` fills
  its own map first). `redert` and `dc-linear` ran on the v2 scenes only.
- Time: wall time of one call on the whole image, compilation excluded, single process.
- Machine: {machine["cpu"]}, {machine["cores"]} cores, numba {machine["numba"]} with
  {machine["numba_threads"]} threads, numpy {machine["numpy"]}, Python {machine["python"]}.
- `{DEFAULT_METHOD}` (the default) parameters: `{json.dumps(defaults, default=str)}`; every
  other method with its own defaults; `sgm-accurate` the same with `median`
  `"weighted-planes"` and its stages `{json.dumps(FIXED_OPTIONS["sgm-accurate"])}`.
{opencv_text}
## Per group of scenes

{group_table(rows, methods)}

## bad-1.0 nonocc, every scene

{scene_table(rows, [m for m in methods if m not in METHODS_V2])}

## bad-0.5 nonocc, every scene

{scene_table(rows, [m for m in methods if m not in METHODS_V2], key="bad-0.5")}

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
    headline = readme_table(rows)
    update_readme(args.readme, headline)
    if args.json is not None:
        payload = [{k: v for k, v in r.items() if k != "result"} for r in rows]
        with io.atomic_write(args.json) as tmp:
            tmp.write_text(json.dumps({"machine": machine, "rows": payload}, indent=1))
    print(headline)
    print(group_table(rows, methods))
    return 0


if __name__ == "__main__":
    assert set(METHODS_ALL) | set(METHODS_V2) == set(METHODS), "a method left out of RESULTS"
    sys.exit(main())
