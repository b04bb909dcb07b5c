"""The methods of :func:`dcstereo.match`: each a named list of stages (a plain dict of them).

* ``sgm``: ``sgm``, the default: census and colour costs, semi-global paths, a
  left-right check, the colour fill, the median and the sub-pixel fit; and
  ``sgm-accurate``, the same stages with the five that win on the development scenes on;
* ``dc``: ``dc`` and ``dc-linear``, the paper's divide and conquer;
* ``dsi``: ``dsi3`` and ``dsi5``, the scanline DPs; ``block``: ``block``;
* ``gcp``: ``dsi3-gcp``; ``redert``: ``redert``;
* ``_pipeline``: what a method and a stage are; ``_bands``: what the paper's
  methods share (the band kernels' memory bounds).

A new method is a new entry: a :class:`~dcstereo.methods._pipeline.Method` whose stages are
existing ones, or new functions of arrays, for example
``Method("mine", (core("mine", my_match, "costs + DP"), MEDIAN, FILL))``.
"""

from dcstereo.methods import block, dc, dsi, gcp, redert, sgm
from dcstereo.methods._pipeline import FILL, MEDIAN, REFINE, SUBPIXEL, Method, Stage, core

#: Every method by name (the order of :data:`dcstereo.params.METHODS`).
REGISTRY: dict[str, Method] = {
    method.name: method
    for method in (
        sgm.METHOD,
        sgm.ACCURATE,
        dc.METHOD,
        dc.LINEAR,
        dsi.DSI5,
        dsi.DSI3,
        gcp.METHOD,
        redert.METHOD,
        block.METHOD,
    )
}

__all__ = ["FILL", "MEDIAN", "REFINE", "REGISTRY", "SUBPIXEL", "Method", "Stage", "core"]
