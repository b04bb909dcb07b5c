"""Sweep the ``redert`` costs and orientation sets on the four development scenes.

    python scripts/tune_redert.py --out docs/redert_tuning.md

Every setting runs on tsukuba, venus, teddy and cones (filled maps, ``window=5``,
``occlusion_cost=10``, the scene's disparity range) and is scored with
:func:`dcstereo.evaluation.score`; ``dsi3`` is the reference. The criterion for the
defaults is the mean over the four scenes (no per-scene tuning); the synthetic slanted
planes of ``tests/test_redert.py`` must still be followed (``slant_cost`` below the
occlusion cost, see the notes the script writes).
"""

import argparse
import time
from pathlib import Path

import numpy as np

import dcstereo
from dcstereo import io
from dcstereo.datasets import load_scene, middlebury_dir
from dcstereo.evaluation import machine_description, score

SCENES = ("tsukuba", "venus", "teddy", "cones")
QUARTER = (-0.5, -0.25, 0.0, 0.25, 0.5)
EIGHTH = (-0.5, -0.25, -0.125, 0.0, 0.125, 0.25, 0.5)
SIXTEENTH = (-0.5, -0.25, -0.125, -0.0625, 0.0, 0.0625, 0.125, 0.25, 0.5)

#: (label, method, options): the former defaults (quarter slopes, slant 8, orientation 5),
#: the cost grid of the eighth-pixel set (slant_cost must stay below occlusion_cost 10:
#: from 10 up, planes of slope 1/2 are cut into occlusions and tests/test_redert.py
#: fails), the other sets at the chosen costs, dsi3 at lower occlusion costs.
SETTINGS = [("dsi3", "dsi3", {})]
SETTINGS += [
    (
        f"quarter slant {s:g} orient {o:g}",
        "redert",
        dict(orientations=QUARTER, slant_cost=s, orientation_cost=o),
    )
    for s, o in ((8, 5), (9, 2))
]
SETTINGS += [
    (
        f"eighth slant {s:g} orient {o:g}",
        "redert",
        dict(orientations=EIGHTH, slant_cost=s, orientation_cost=o),
    )
    for s in (6, 8, 9)
    for o in (2, 5, 10)
]
SETTINGS += [
    (
        f"sixteenth slant {s:g} orient {o:g}",
        "redert",
        dict(orientations=SIXTEENTH, slant_cost=s, orientation_cost=o),
    )
    for s, o in ((8, 5), (9, 2))
]
SETTINGS += [(f"dsi3 occlusion {c:g}", "dsi3", dict(occlusion_cost=c)) for c in (5, 7)]


def run(scenes, method, options):
    """Scores and seconds of one setting on every scene (single call, after a warm-up)."""
    rows = []
    for scene in scenes:
        start = time.perf_counter()
        result = dcstereo.match(
            scene.left,
            scene.right,
            max_disparity=scene.max_disparity,
            method=method,
            fill=True,
            **options,
        )
        seconds = time.perf_counter() - start
        scores = score(result.disparity, scene)
        rows.append(
            (
                scores["nonocc"]["bad-1.0"],
                scores["all"]["bad-1.0"],
                scores["disc"]["bad-1.0"],
                scores["nonocc"]["bad-0.5"],
                scores["nonocc"]["mae"],
                seconds,
            )
        )
    return np.array(rows)


def cell(row):
    return f"{row[0]:.2f} / {row[1]:.2f} / {row[2]:.2f} / {row[3]:.2f} / {row[4]:.3f}"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=middlebury_dir())
    parser.add_argument("--out", type=Path, default=None, help="markdown file to write")
    args = parser.parse_args(argv)
    scenes = [load_scene(args.data / name) for name in SCENES]
    small = scenes[0]
    for method, options in (("dsi3", {}), ("redert", dict(orientations=SIXTEENTH))):
        dcstereo.match(
            small.left[:12], small.right[:12], max_disparity=15, method=method, **options
        )
    lines = [
        "| setting | " + " | ".join(SCENES) + " | mean | time (s) |",
        "| --- |" + " ---: |" * (len(SCENES) + 2),
    ]
    for label, method, options in SETTINGS:
        rows = run(scenes, method, options)
        mean = rows.mean(axis=0)
        line = (
            f"| {label} | "
            + " | ".join(cell(r) for r in rows)
            + f" | {cell(mean)} | {rows[:, 5].sum():.2f} |"
        )
        print(line, flush=True)
        lines.append(line)
    machine = machine_description()
    text = (
        "Each cell: bad-1.0 nonocc / all / disc, bad-0.5 nonocc (%), MAE nonocc (px); "
        "filled maps, `window=5`, `occlusion_cost=10` unless named; time: the four "
        f"scenes, one call each. Machine: {machine['cpu']}, numba "
        f"{machine['numba']} with {machine['numba_threads']} threads.\n\n" + "\n".join(lines)
    )
    if args.out is not None:
        with io.atomic_write(args.out) as tmp:
            tmp.write_text(text + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
