"""Refinement candidates for scripts/eval_refine.py (each registers itself)."""

from dataclasses import replace

import numpy as np
from eval_refine import finish

from dcstereo.result import FLAG_BORDER, FLAG_MISMATCH, FLAG_OCCLUDED

REGISTRY = {}


def register(name):
    def deco(fn):
        REGISTRY[name] = fn
        return fn

    return deco


@register("border-as-mismatch")
def cand_border(pair, raw, margin, colour, params):
    flags = raw.flags.copy()
    b = (flags & FLAG_BORDER) != 0
    flags[b] = (flags[b] & ~np.uint8(FLAG_BORDER)) | np.uint8(FLAG_MISMATCH)
    return finish(replace(raw, flags=flags), colour, params).disparity


@register("occl-as-mismatch")
def cand_occl(pair, raw, margin, colour, params):
    flags = raw.flags.copy()
    b = np.isnan(raw.disparity)
    flags[b] = np.uint8(FLAG_MISMATCH)
    return finish(replace(raw, flags=flags), colour, params).disparity


def _lowconf(t):
    def cand(pair, raw, margin, colour, params):
        d = raw.disparity.copy()
        flags = raw.flags.copy()
        low = np.isfinite(d) & (margin < t)
        d[low] = np.nan
        flags[low] |= np.uint8(FLAG_MISMATCH)
        return finish(replace(raw, disparity=d, flags=flags), colour, params).disparity

    return cand


for _t in (0.02, 0.05, 0.1):
    register(f"lowconf-{_t}")(_lowconf(_t))


from dcstereo.refine.planes import segment_planes  # noqa: E402


def _planes(holes="mismatch", conf=None, replace_below=None, **kw):
    def cand(pair, raw, margin, colour, params):
        d = raw.disparity
        usable = None if conf is None else (margin >= conf)
        if holes == "mismatch":  # occluded / border pixels left to the background fill
            replaceable = (raw.flags & (FLAG_OCCLUDED | FLAG_BORDER)) == 0
        else:
            replaceable = np.ones(d.shape, dtype=bool)
        if replace_below is not None:  # estimates replaced only where not confident
            replaceable = replaceable & (np.isnan(d) | (margin < replace_below))
        out = segment_planes(
            d,
            colour,
            usable=usable,
            replaceable=replaceable,
            low=pair.min_disparity,
            high=pair.max_disparity,
            **kw,
        )
        flags = raw.flags.copy()
        new = np.isnan(d) & np.isfinite(out)
        flags[new] = 0
        return finish(
            replace(raw, disparity=out.astype(np.float32), flags=flags), colour, params
        ).disparity

    return cand


register("planes")(_planes())
register("planes-all")(_planes(holes="all"))
register("planes-c05")(_planes(conf=0.05))
register("planes-s24")(_planes(step=24))
register("planes-s12")(_planes(step=12))
register("planes-o1")(_planes(outlier=1.0))
register("planes-o3")(_planes(outlier=3.0))
register("planes-r5")(_planes(min_ratio=0.5))
register("planes-r7")(_planes(min_ratio=0.7))
register("planes-rb0")(_planes(replace_below=0.0))
register("planes-rb05")(_planes(replace_below=0.05))
register("planes-rb1")(_planes(replace_below=0.1))
register("planes-rb2")(_planes(replace_below=0.2))
register("planes-rb1-s12")(_planes(replace_below=0.1, step=12))
register("planes-rb1-c05")(_planes(replace_below=0.1, conf=0.05))
register("planes-rb2-it1")(_planes(replace_below=0.2, slic_iterations=1))
register("planes-rb2-it2")(_planes(replace_below=0.2, slic_iterations=2))
register("planes-rb3")(_planes(replace_below=0.3))
register("planes-rb2-c05")(_planes(replace_below=0.2, conf=0.05))
register("planes-rb2-all")(_planes(replace_below=0.2, holes="all"))
register("planes-rb2-m10")(_planes(replace_below=0.2, compactness=10.0))
register("planes-rb2-m40")(_planes(replace_below=0.2, compactness=40.0))


def _planes2(border=True, **kw):
    """planes-rb2-c05 with the left border's pixels (FLAG_BORDER) replaceable too."""

    def cand(pair, raw, margin, colour, params):
        d = raw.disparity
        excluded = FLAG_OCCLUDED if border else (FLAG_OCCLUDED | FLAG_BORDER)
        replaceable = ((raw.flags & excluded) == 0) & (np.isnan(d) | (margin < 0.2))
        out = segment_planes(
            d,
            colour,
            usable=margin >= 0.05,
            replaceable=replaceable,
            low=pair.min_disparity,
            high=pair.max_disparity,
            **kw,
        )
        flags = raw.flags.copy()
        flags[np.isnan(d) & np.isfinite(out)] = 0
        return finish(
            replace(raw, disparity=out.astype(np.float32), flags=flags), colour, params
        ).disparity

    return cand


register("planes-border")(_planes2())
register("planes-border-m10")(_planes2(compactness=10.0))
register("planes-m10-c05")(_planes2(border=False, compactness=10.0))
register("planes-m10-c05-in15")(_planes2(border=False, compactness=10.0, inlier=1.5))
register("planes-m10-c05-in07")(_planes2(border=False, compactness=10.0, inlier=0.7))


# region voting over cross-based regions (ADCensus): kernels at commit 68036a5 of branch
# acc-refine (src/dcstereo/voting.py), measured v2 3.05, new 7.88, KITTI D1 10.30; removed.
register("p15-s02")(_planes2(border=False, compactness=10.0, inlier=1.5, min_support=0.2))
register("p15-s05")(_planes2(border=False, compactness=10.0, inlier=1.5, min_support=0.5))
register("p15-r5")(_planes2(border=False, compactness=10.0, inlier=1.5, min_ratio=0.5))
register("p15-r7")(_planes2(border=False, compactness=10.0, inlier=1.5, min_ratio=0.7))
register("p20")(_planes2(border=False, compactness=10.0, inlier=2.0))
register("p15-it2")(_planes2(border=False, compactness=10.0, inlier=1.5, slic_iterations=2))
register("p15-o3")(_planes2(border=False, compactness=10.0, inlier=1.5, outlier=3.0))


from dcstereo.refine.planes import refine_planes  # noqa: E402


@register("refine-planes")
def cand_refine_planes(pair, raw, margin, colour, params):
    """The library's stage (dcstereo.refine.planes.refine_planes, defaults), as sgm(planes=True)."""
    return finish(refine_planes(raw, colour, margin), colour, params).disparity


@register("sgm-planes")
def cand_sgm_planes(pair, raw, margin, colour, params):
    """The whole pipeline, uncached: dcstereo.match(..., planes=True)."""
    import dcstereo

    return dcstereo.match(
        pair.left,
        pair.right,
        max_disparity=pair.max_disparity,
        min_disparity=pair.min_disparity,
        planes=True,
    ).disparity


@register("sgm")
def cand_sgm(pair, raw, margin, colour, params):
    """The whole pipeline, uncached: dcstereo.match(...)."""
    import dcstereo

    return dcstereo.match(
        pair.left, pair.right, max_disparity=pair.max_disparity, min_disparity=pair.min_disparity
    ).disparity


from dcstereo.refine.planes import PlaneParams  # noqa: E402


def _two(first, second, second_holes_only=True):
    def cand(pair, raw, margin, colour, params):
        r = refine_planes(raw, colour, margin, PlaneParams(**first))
        m2 = margin
        if second_holes_only:  # only the holes still open: no estimate is replaceable
            m2 = np.where(np.isnan(r.disparity), margin, 1.0).astype(np.float32)
        r = refine_planes(r, colour, m2, PlaneParams(**second))
        return finish(r, colour, params).disparity

    return cand


def _one(**kw):
    """refine_planes with PlaneParams(**kw) (the candidates measured before a default
    changed ran with the defaults of their commit)."""

    def cand(pair, raw, margin, colour, params):
        return finish(
            refine_planes(raw, colour, margin, PlaneParams(**kw)), colour, params
        ).disparity

    return cand


register("two-16-32")(_two({"steps": (16,)}, {"steps": (32,)}))
register("two-16-32-all")(_two({"steps": (16,)}, {"steps": (32,)}, False))
register("two-32-16")(_two({"steps": (32,)}, {"steps": (16,)}, False))
register("two-16-24")(_two({"steps": (16,)}, {"steps": (24,)}, False))
register("one-rm3")(_one(replace_margin=0.3))
register("one-fm1")(_one(fit_margin=0.1))
register("one-fm0")(_one(fit_margin=0.0))
register("one-s20")(_one(steps=(20,)))


def _multi(*steps, **kw):
    def cand(pair, raw, margin, colour, params):
        r = raw
        for s in steps:
            r = refine_planes(r, colour, margin, PlaneParams(steps=(s,), **kw))
        return finish(r, colour, params).disparity

    return cand


register("m-48-32-16")(_multi(48, 32, 16))
register("m-32-16-24")(_multi(32, 16, 24))
register("m-32-24-16")(_multi(32, 24, 16))
register("m-24-16")(_multi(24, 16))
register("m-32-16-it1")(_multi(32, 16, slic_iterations=1))
register("m-32-16-i100")(_multi(32, 16, iterations=100))
register("m-32-16-rm3")(_multi(32, 16, replace_margin=0.3))
register("f321-it2")(_one(slic_iterations=2))
register("s48-32-16")(_one())
register("s48-32-16-it1")(_one(slic_iterations=1))
register("s48-32-16-it2")(_one(slic_iterations=2))
register("s32-16")(_one(steps=(32, 16)))
register("s64-32-16")(_one(steps=(64, 32, 16)))
register("s48-24")(_one(steps=(48, 24)))
register("s3-rm1")(_one(replace_margin=0.1))
register("s3-r7")(_one(min_ratio=0.7))
register("s3-in1")(_one(inlier=1.0))
register("s3-o3")(_one(outlier=3.0))
register("s3-sup5")(_one(min_support=0.5))
register("s3-rm15")(_one(replace_margin=0.15))
register("s3-rm1-in125")(_one(replace_margin=0.1, inlier=1.25))
register("s3-rm15-in125")(_one(replace_margin=0.15, inlier=1.25))
register("s3-rm1-it2")(_one(replace_margin=0.1, slic_iterations=2))
register("sc2")(_one(slic_scale=2))
register("sc2-i100")(_one(slic_scale=2, iterations=100))
register("sc2-it2")(_one(slic_scale=2, slic_iterations=2))
register("sc1-i100-it2")(_one(iterations=100, slic_iterations=2))
register("ms32")(_one(max_scored=32))
register("ms128")(_one(max_scored=128))
register("ms-all")(_one(max_scored=2**30))
