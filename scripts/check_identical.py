"""Bit-for-bit guard: run a fixed set of matches and compare every output array.

    python scripts/check_identical.py --save /tmp/reference.npz    # before a change
    python scripts/check_identical.py --compare /tmp/reference.npz # after it

``--save`` runs every case below and stores each output array (disparity, flags,
path_cost, features where present, and the extras: confidence maps, orientation maps);
``--compare`` runs them again and reports every array that differs from the stored one in
dtype, shape or any byte (NaN compared by its bits), and every array missing or new: exit
status 1, or "N arrays bit for bit" and 0. ``--only SUBSTRING`` runs the cases whose name
contains it (a quick check of one path; the comparison is then of those arrays only).

The cases: the four Middlebury v2 scenes (tsukuba, venus, teddy, cones, each with its own
disparity range) with every method (``sgm`` since the kernel merge: the 599 arrays of that
check did not hold it) and the options that choose another kernel path
(``cost="bt"``, the left-right check, fill, sub-pixel fits, the median, the confidence,
``max_candidates`` and ``uniqueness=0``, which run ``dc`` row by row); ``dc``'s and
``dsi3-gcp``'s band modes 2 and 3 and the row-by-row Birchfield-Tomasi paths forced by
lowering ``mbands.DC_BAND_BYTES`` and ``mbands.BAND_ARRAY_BYTES``; a wide synthetic pair whose
band array passes ``DC_BAND_BYTES`` (mode 3 with the defaults); ``redert`` on crops; the
inputs of every signal mode (gray, uint16, float, RGBA); and ``tiling.match_tiled``.
The results do not depend on numba's thread count.
"""

import argparse
import contextlib
import dataclasses
import sys
import time

import numpy as np

import dcstereo
from dcstereo.batch.tiling import match_tiled
from dcstereo.evaluation.datasets import load_middlebury
from dcstereo.methods import _bands as mbands
from dcstereo.methods.redert import match_redert
from dcstereo.refine.confidence import confidence

SCENES = ("tsukuba", "venus", "teddy", "cones")


@contextlib.contextmanager
def patched(**values):
    """Set the band bounds (``DC_BAND_BYTES``, ``BAND_ARRAY_BYTES``) for a block."""
    old = {name: getattr(mbands, name) for name in values}
    try:
        for name, value in values.items():
            setattr(mbands, name, value)
        yield
    finally:
        for name, value in old.items():
            setattr(mbands, name, value)


def result_arrays(result):
    """Every array field of a ``DisparityResult`` (None fields left out)."""
    out = {}
    for field in dataclasses.fields(result):
        value = getattr(result, field.name)
        if isinstance(value, np.ndarray):
            out[field.name] = value
    return out


def wide_pair(seed=7, height=24, width=1100, max_disparity=127):
    """A textured pair of two planes, wide enough that ``dc``'s band array passes 8 MiB."""
    rng = np.random.default_rng(seed)
    right = rng.integers(0, 256, (height, width + max_disparity), dtype=np.uint8)
    right = (right.astype(np.float64) * 0.6 + np.roll(right, 1, axis=1) * 0.4).astype(np.uint8)
    left = np.empty((height, width), dtype=np.uint8)
    for y in range(height):
        d = 20 if y < height // 2 else 90
        left[y] = right[y, max_disparity - d : max_disparity - d + width]
    # a near object in the middle of the left view
    left[:, 500:620] = right[:, max_disparity - 110 + 500 : max_disparity - 110 + 620]
    return left, right[:, max_disparity:], max_disparity


def scene_cases(name, scene):
    """Cases of one Middlebury scene: ``(case name, function returning {key: array})``."""
    left, right = scene.left, scene.right
    rng = {"max_disparity": scene.max_disparity, "min_disparity": scene.min_disparity}

    def run(**options):
        return lambda: result_arrays(dcstereo.match(left, right, **rng, **options))

    def with_confidence(**options):
        def go():
            result = dcstereo.match(left, right, **rng, **options)
            arrays = result_arrays(result)
            arrays["confidence"] = confidence(result, left, right)
            return arrays

        return go

    def forced(constants, **options):
        def go():
            with patched(**constants):
                return result_arrays(dcstereo.match(left, right, **rng, **options))

        return go

    cases = {
        # the 108 arrays of the earlier checks
        "dc": with_confidence(method="dc"),
        "dc-bt": with_confidence(method="dc", cost="bt"),
        "dc-lr": run(method="dc", lr_check=True),
        "dc-fill": run(method="dc", fill=True),
        "dc-linear": run(method="dc-linear"),
        "dsi5": run(method="dsi5"),
        "dsi3-gcp": run(method="dsi3-gcp"),
        # the other methods and options
        "dsi3": run(method="dsi3"),
        "block": run(method="block"),
        "dsi5-bt": with_confidence(method="dsi5", cost="bt"),
        "dsi3-bt": run(method="dsi3", cost="bt"),
        "block-bt": run(method="block", cost="bt"),
        "dsi3-gcp-bt": run(method="dsi3-gcp", cost="bt"),
        "dc-lr-bt": run(method="dc", lr_check=True, cost="bt"),
        "dc-linear-bt": run(method="dc-linear", cost="bt"),
        "dc-equiangular": run(method="dc", subpixel="equiangular"),
        "dsi5-parabola-bt": run(method="dsi5", subpixel="parabola", cost="bt"),
        "dc-median": run(method="dc", median=5),
        "dsi5-parabola-median": run(method="dsi5", subpixel="parabola", median=3),
        "dc-fill-median": run(method="dc", fill=True, median=3),
        "dc-candidates": run(method="dc", max_candidates=3),
        "dc-uniqueness0": run(method="dc", uniqueness=0),
        "dc-uniqueness0-lr": run(method="dc", uniqueness=0, lr_check=True),
        "dc-candidates-bt": run(method="dc", max_candidates=2, cost="bt"),
        "dc-relative-guard": run(method="dc", vs_relative=True, edge_guard=0),
        "dsi5-window9": run(method="dsi5", window=9, occlusion_cost=6),
        # sgm, the default: its pipeline, its confidence, and the options of other paths
        "sgm": with_confidence(method="sgm"),
        "sgm-census-4paths": run(method="sgm", cost="census", paths=4, subpixel="parabola"),
        "sgm-raw": run(method="sgm", fill=False, median=0, subpixel="none", lr_tolerance=0),
        # dc's and dsi3-gcp's band mode 3 (no band array), by the bound
        "dc-mode3": forced({"DC_BAND_BYTES": 0}, method="dc"),
        "dsi3-gcp-mode3": forced({"DC_BAND_BYTES": 0}, method="dsi3-gcp"),
        # row by row: the arrays that would not fit the memory bound
        "rows-block-bt": forced({"BAND_ARRAY_BYTES": 0}, method="block", cost="bt"),
        "rows-dsi5-bt": forced({"BAND_ARRAY_BYTES": 0}, method="dsi5", cost="bt"),
        "rows-dsi3-bt": forced({"BAND_ARRAY_BYTES": 0}, method="dsi3", cost="bt"),
        "rows-dc-bt": forced({"BAND_ARRAY_BYTES": 0}, method="dc", cost="bt"),
        "rows-dsi3-gcp-bt": forced({"BAND_ARRAY_BYTES": 0}, method="dsi3-gcp", cost="bt"),
        "rows-dc-lr": forced(
            {"BAND_ARRAY_BYTES": 0, "DC_BAND_BYTES": 0}, method="dc", lr_check=True
        ),
    }
    return {f"{name}/{case}": fn for case, fn in cases.items()}


def other_cases(scenes):
    """Cases beyond the scenes' full-size runs."""
    cases = {}
    tsukuba = scenes["tsukuba"]
    teddy = scenes["teddy"]

    # redert on crops (slow on whole scenes), with its orientation map
    def redert(scene, rows, cols, **options):
        def go():
            left = scene.left[rows, cols]
            right = scene.right[rows, cols]
            params = dcstereo.MatchParams(
                max_disparity=scene.max_disparity, method="redert", **options
            )
            result, slopes = match_redert(left, right, params, with_orientation=True)
            arrays = result_arrays(result)
            arrays["orientation"] = slopes
            return arrays

        return go

    cases["redert/tsukuba-crop"] = redert(tsukuba, slice(120, 160), slice(40, 240))
    cases["redert/teddy-crop"] = redert(teddy, slice(200, 230), slice(100, 300))
    cases["redert/teddy-crop-discount"] = redert(
        teddy, slice(200, 220), slice(150, 330), occlusion_discount=0.5
    )

    def match_on(left, right, **options):
        return lambda: result_arrays(dcstereo.match(left, right, **options))

    # every signal mode: gray uint8, uint16, float, RGBA (the scenes are RGB uint8)
    left, right = teddy.left[100:180], teddy.right[100:180]
    gray_l = left.mean(axis=2).astype(np.uint8)
    gray_r = right.mean(axis=2).astype(np.uint8)
    d = {"max_disparity": teddy.max_disparity}
    cases["signal/gray-dsi5"] = match_on(gray_l, gray_r, method="dsi5", **d)
    cases["signal/uint16-dc"] = match_on(
        left.astype(np.uint16) * 257 + 3, right.astype(np.uint16) * 257, method="dc", **d
    )
    cases["signal/float-dsi3"] = match_on(
        left.astype(np.float32) / 255, right.astype(np.float32) / 255, method="dsi3", **d
    )
    alpha = np.full((*left.shape[:2], 1), 255, dtype=np.uint8)
    cases["signal/rgba-block"] = match_on(
        np.concatenate([left, alpha], axis=2), np.concatenate([right, alpha], axis=2),
        method="block", **d,
    )  # fmt: skip
    cases["signal/gray-colour-dc"] = match_on(gray_l, right, method="dc", **d)

    # a wide synthetic pair: dc's band array passes DC_BAND_BYTES (mode 3 with the defaults)
    wl, wr, wd = wide_pair()
    for method, options in (
        ("dc", {}),
        ("dc-lr", {"lr_check": True}),
        ("dc-bt", {"cost": "bt"}),
        ("dc-linear", {}),
        ("dsi3-gcp", {}),
        ("dsi5", {}),
        ("block-bt", {"cost": "bt"}),
    ):
        name = method.removesuffix("-lr").removesuffix("-bt")
        cases[f"wide/{method}"] = match_on(wl, wr, method=name, max_disparity=wd, **options)

    def wide_forced(constants, **options):
        def go():
            with patched(**constants):
                return result_arrays(dcstereo.match(wl, wr, max_disparity=wd, **options))

        return go

    cases["wide/rows-dc-bt"] = wide_forced({"BAND_ARRAY_BYTES": 0}, method="dc", cost="bt")
    cases["wide/rows-dsi5-bt"] = wide_forced({"BAND_ARRAY_BYTES": 0}, method="dsi5", cost="bt")
    cases["wide/rows-dc-lr"] = wide_forced({"BAND_ARRAY_BYTES": 0}, method="dc", lr_check=True)
    cases["wide/rows-gcp-bt"] = wide_forced({"BAND_ARRAY_BYTES": 0}, method="dsi3-gcp", cost="bt")

    # a negative minimum disparity (a shifted range) on a crop
    cl, cr = tsukuba.left[:96], tsukuba.right[:96]
    for method in ("dc", "dsi5", "dsi3-gcp", "block"):
        cases[f"shifted/{method}"] = match_on(
            cl, cr, method=method, min_disparity=-4, max_disparity=11
        )

    # tiling: bands matched one after the other and stitched
    for method in ("dc", "dsi5"):
        cases[f"tiled/{method}"] = lambda m=method: result_arrays(
            match_tiled(tsukuba.left, tsukuba.right, tile_rows=50, max_disparity=15, method=m)
        )
    return cases


def all_cases():
    scenes = {name: load_middlebury(name) for name in SCENES}
    cases = {}
    for name, scene in scenes.items():
        cases.update(scene_cases(name, scene))
    cases.update(other_cases(scenes))
    return cases


def run_cases(only=None):
    arrays = {}
    for case, fn in all_cases().items():
        if only and not any(o in case for o in only):
            continue
        start = time.perf_counter()
        for key, value in fn().items():
            arrays[f"{case}/{key}"] = np.ascontiguousarray(value)
        print(f"  {case}: {time.perf_counter() - start:.1f} s", file=sys.stderr, flush=True)
    return arrays


def same(a, b):
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--save", metavar="FILE.npz")
    group.add_argument("--compare", metavar="FILE.npz")
    parser.add_argument("--only", action="append", help="run only cases containing this")
    args = parser.parse_args(argv)
    arrays = run_cases(args.only)
    if args.save:
        np.savez_compressed(args.save, **arrays)
        print(f"{len(arrays)} arrays saved to {args.save}")
        return 0
    with np.load(args.compare) as stored:
        reference = {k: stored[k] for k in stored.files}
    if args.only:
        reference = {k: v for k, v in reference.items() if any(o in k for o in args.only)}
    bad = []
    for key in sorted(set(reference) | set(arrays)):
        if key not in arrays:
            bad.append(f"missing: {key}")
        elif key not in reference:
            bad.append(f"new (not in the reference): {key}")
        elif not same(reference[key], arrays[key]):
            a, b = reference[key], arrays[key]
            detail = f"{a.dtype}{a.shape} -> {b.dtype}{b.shape}"
            if a.shape == b.shape and a.dtype == b.dtype:
                bytes_a, bytes_b = (np.frombuffer(v.tobytes(), np.uint8) for v in (a, b))
                detail += f", {int((bytes_a != bytes_b).sum())} bytes differ"
            bad.append(f"differs: {key} ({detail})")
    if bad:
        print("\n".join(bad))
        print(f"{len(bad)} of {len(reference)} arrays not bit for bit")
        return 1
    print(f"{len(arrays)} arrays bit for bit")
    return 0


if __name__ == "__main__":
    sys.exit(main())
