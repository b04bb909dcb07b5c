"""After the match: left-right consistency and fill, median, sub-pixel fit, confidence.

* :mod:`.consistency`: the fill of the pixels a left-right check rejected;
* :mod:`.postfilter`: the median post-filter;
* :mod:`.subpixel`: sub-pixel refinement of whole-pixel estimates;
* :mod:`.confidence`: a confidence map per estimate.

Each public module wraps the numba kernels of its private twin (``_median``,
``_postfilter``, ``_subpixel``, ``_confidence``, ``_consistency``).
"""
