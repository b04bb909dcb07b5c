"""Refinement candidates for scripts/eval_refine.py (each registers itself)."""

from dataclasses import replace

import numpy as np

from dcstereo.result import FLAG_BORDER, FLAG_MISMATCH, FLAG_OCCLUDED

from eval_refine import finish

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


from dcstereo.planes import segment_planes  # noqa: E402


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
        out = segment_planes(d, colour, usable=usable, replaceable=replaceable,
                             low=pair.min_disparity, high=pair.max_disparity, **kw)
        flags = raw.flags.copy()
        new = np.isnan(d) & np.isfinite(out)
        flags[new] = 0
        return finish(replace(raw, disparity=out.astype(np.float32), flags=flags), colour,
                      params).disparity
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
