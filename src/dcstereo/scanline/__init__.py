"""The scanline optimisers of the paper's section 3.

* ``dp``: the disparity-space DP of one scanline, three steps [4] or the paper's five
  (eq. 5), free or through anchors;
* ``band_dp``: the same DP for a band of rows in lockstep;
* ``rows``: ``dsi3``, ``dsi5`` and ``block`` row by row (costs then DP);
* ``redert``: the DP of Redert et al. [6], with surface orientations.
"""
