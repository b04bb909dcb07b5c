"""Score refinement stages after ``sgm``'s left-right check, indoors and outdoors.

``sgm`` runs once per scene with ``fill=False`` (its map with the left-right check's holes
and their reason flags, and the confidence margin), cached under ``--cache`` (``/tmp`` by
default), so that a refinement experiment costs only its own stages. Each candidate is a
function of the raw result that returns the final dense map; ``base`` (the fill, the
median of 5, the background fill) reproduces ``dcstereo.match(method="sgm")``.

Scores: bad-1.0 over ``nonocc`` for the 22 Middlebury development scenes (v2: tsukuba,
venus, teddy, cones; "new": the other 17 and Motorcycle), and for the KITTI pairs under
``outdoor/`` bad-2, bad-3 and D1 (error over 3 px and over 5 % of the truth) over every
pixel with ground truth, dense (a pixel without an estimate counts wrong)::

    python scripts/eval_refine.py                      # base only
    python scripts/eval_refine.py --candidates base,planes --scenes teddy,Piano
    python scripts/eval_refine.py --candidates planes --per-scene
    python scripts/eval_refine.py --candidates base,stage --plane-params "{'slic_iterations': 2}"

``stage`` is the library's stage (``refine_planes``) with the ``PlaneParams`` of
``--plane-params``.
"""

import argparse
import ast
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from dcstereo.evaluation.datasets import (
    default_data_dir,
    find_scenes,
    load_motorcycle,
    load_scene,
    middlebury_dir,
)
from dcstereo.evaluation.metrics import bad_pixel_rate, d1_rate
from dcstereo.methods.sgm import _run, colour_channels
from dcstereo.params import MatchParams
from dcstereo.refine.consistency import fill_with_colour
from dcstereo.refine.postfilter import median_filter
from dcstereo.result import DisparityResult

V2 = ("tsukuba", "venus", "teddy", "cones")


class Pair:
    """A scene: images, truth, range, evaluation mask and kind ("v2", "new", "kitti")."""

    def __init__(self, name, left, right, truth, mask, dmin, dmax, kind):
        self.name, self.left, self.right, self.truth, self.mask = name, left, right, truth, mask
        self.min_disparity, self.max_disparity, self.kind = dmin, dmax, kind


def middlebury_pairs():
    scenes = [load_scene(folder) for folder in find_scenes(middlebury_dir())]
    scenes.append(load_motorcycle())
    return [
        Pair(s.name, s.left, s.right, s.disparity, s.masks["nonocc"], s.min_disparity,
             s.max_disparity, "v2" if s.name in V2 else "new")
        for s in scenes
    ]  # fmt: skip


def kitti_pairs():
    root = Path(default_data_dir()) / "outdoor"
    out = []
    for folder in sorted(p for p in root.iterdir() if (p / "meta.json").exists()):
        scene = load_scene(folder)  # the one-pair KITTI layout: truth NaN where none
        truth = scene.disparity.astype(np.float32)
        out.append(
            Pair(folder.name, scene.left, scene.right, truth, np.isfinite(truth), 0,
                 scene.max_disparity, "kitti")
        )  # fmt: skip
    return out


def sgm_params(pair, **options):
    return MatchParams(max_disparity=pair.max_disparity, min_disparity=pair.min_disparity,
                       method="sgm", **options)  # fmt: skip


def raw_sgm(pair, cache: Path):
    """``sgm``'s unfilled result and its confidence margin, cached per scene."""
    params = sgm_params(pair)
    path = cache / f"{pair.name}.npz"
    if path.exists():
        data = np.load(path)
        result = DisparityResult(data["disparity"], data["flags"], replace(params, fill=False),
                                 np.full(pair.left.shape[0], np.nan))  # fmt: skip
        return result, data["margin"], 0.0
    start = time.perf_counter()
    result, margin = _run(pair.left, pair.right, replace(params, fill=False), True)
    seconds = time.perf_counter() - start
    np.savez(path, disparity=result.disparity, flags=result.flags, margin=margin)
    return result, margin, seconds


def finish(result, colour, params):
    """sgm's own end: the colour fill, the median, the background fill."""
    result = fill_with_colour(result, colour)
    if params.median:
        result = median_filter(result, params.median)
    return result.filled()


# ---- candidates: raw result -> final dense disparity ------------------------------------


def cand_base(pair, raw, margin, colour, params):
    return finish(raw, colour, params).disparity


#: ``PlaneParams`` of the ``stage`` candidate (``--plane-params``).
PLANE_OPTIONS = {}


def cand_stage(pair, raw, margin, colour, params):
    """``refine_planes`` with ``PlaneParams(**PLANE_OPTIONS)``, then sgm's own end."""
    from dcstereo.refine.planes import PlaneParams, refine_planes

    refined = refine_planes(raw, colour, margin, PlaneParams(**PLANE_OPTIONS))
    return finish(refined, colour, params).disparity


CANDIDATES = {"base": cand_base, "stage": cand_stage}


def register(name):
    def deco(fn):
        CANDIDATES[name] = fn
        return fn

    return deco


def load_candidates():
    """Add the candidates of scripts/refine_candidates.py (imported here: it imports this)."""
    sys.path.insert(0, str(Path(__file__).parent))
    import refine_candidates

    CANDIDATES.update(refine_candidates.REGISTRY)


# ---- scores ---------------------------------------------------------------------------


def kitti_scores(estimate, truth, mask):
    """bad-1, bad-2, bad-3 and D1 (percent) over ``mask``; NaN estimates count wrong."""
    bad = [bad_pixel_rate(estimate, truth, threshold=t, mask=mask) for t in (1.0, 2.0, 3.0)]
    return (*bad, d1_rate(estimate, truth, mask=mask))


def score(pair, disparity):
    if pair.kind == "kitti":
        return kitti_scores(disparity, pair.truth, pair.mask)
    return (bad_pixel_rate(disparity, pair.truth, threshold=1.0, mask=pair.mask),)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--candidates", default="base")
    parser.add_argument("--scenes", help="comma-separated names (default: all)")
    parser.add_argument("--groups", default="v2,new,kitti")
    parser.add_argument("--per-scene", action="store_true")
    parser.add_argument("--cache", default="/tmp/dcstereo_refine_cache")
    parser.add_argument(
        "--plane-params", default="{}", help="dict of PlaneParams for the 'stage' candidate"
    )
    parser.add_argument("--json", help="write each candidate's scores per scene to this file")
    args = parser.parse_args(argv)
    PLANE_OPTIONS.update(ast.literal_eval(args.plane_params))
    load_candidates()
    cache = Path(args.cache)
    cache.mkdir(parents=True, exist_ok=True)
    groups = args.groups.split(",")
    pairs = []
    if "v2" in groups or "new" in groups:
        pairs += [p for p in middlebury_pairs() if p.kind in groups]
    if "kitti" in groups:
        pairs += kitti_pairs()
    if args.scenes:
        names = args.scenes.split(",")
        pairs = [p for p in pairs if p.name in names]
    names = args.candidates.split(",")
    table = {n: {} for n in names}
    times = {n: 0.0 for n in names}
    sgm_seconds = 0.0
    for pair in pairs:
        raw, margin, seconds = raw_sgm(pair, cache)
        sgm_seconds += seconds
        colour = colour_channels(pair.left, pair.left)[0]
        params = sgm_params(pair)
        for n in names:
            if pair is pairs[0]:  # compile before timing
                CANDIDATES[n](pair, raw, margin, colour, params)
            start = time.perf_counter()
            out = CANDIDATES[n](pair, raw, margin, colour, params)
            times[n] += time.perf_counter() - start
            table[n][pair.name] = (pair.kind, score(pair, out))
        if args.per_scene:
            print(pair.name, " ".join(f"{n}={table[n][pair.name][1][-1]:.2f}" for n in names),
                  flush=True)  # fmt: skip
    if sgm_seconds:
        print(f"(sgm runs, uncached: {sgm_seconds:.1f} s)")
    base = table.get("base")
    for n in names:
        rows = table[n]
        parts = []
        for kind in ("v2", "new"):
            vals = [v[1][0] for v in rows.values() if v[0] == kind]
            if vals:
                wins = ""
                if base is not None and kind == "new" and n != "base":
                    w = sum(rows[k][1][0] < base[k][1][0] for k in rows if rows[k][0] == kind)
                    wins = f" ({w}/{len(vals)} better)"
                parts.append(f"{kind} {np.mean(vals):5.2f}{wins}")
        kit = np.array([v[1] for v in rows.values() if v[0] == "kitti"])
        if len(kit):
            m = kit.mean(axis=0)
            parts.append(f"kitti b1 {m[0]:5.2f} b2 {m[1]:5.2f} b3 {m[2]:5.2f} D1 {m[3]:5.2f}")
        print(f"{n:28s} {'  '.join(parts)}  [{1000 * times[n]:.0f} ms total]", flush=True)
    if args.json:
        ms = {n: 1000 * times[n] for n in names}
        record = {"plane_params": args.plane_params, "scores": table, "ms": ms}
        Path(args.json).write_text(json.dumps(record))
    if args.per_scene and len(names) >= 1:
        print("per scene (bad-1 nonocc / D1):")
        for name in table[names[0]]:
            print(f"  {name:22s} " + " ".join(f"{table[n][name][1][-1]:6.2f}" for n in names))
    return 0


if __name__ == "__main__":
    sys.exit(main())
