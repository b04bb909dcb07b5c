"""After the match: left-right consistency and fill, median, sub-pixel fit, confidence.

* :mod:`.consistency`: the fill of the pixels a left-right check rejected;
* :mod:`.postfilter`: the median post-filter;
* :mod:`.subpixel`: sub-pixel refinement of whole-pixel estimates;
* :mod:`.confidence`: a confidence map per estimate;
* :mod:`.planes`: a robust plane per superpixel of the left image for the mismatches and
  the unsure estimates (``sgm``'s ``planes``).

Each public module wraps the numba kernels of its private twin (``_median``,
``_postfilter``, ``_subpixel``, ``_confidence``, ``_consistency``, ``_planes``).
"""
