"""The paper's section 2: divide and conquer with reliable feature pairs.

* ``divide``: the recursive search on a scanline and the fill between its pairs;
* ``features``: its measures: window variance, SER (eq. 2), VS (eq. 3), the
  uniqueness ratio, the block match;
* ``divide_bands`` and ``band_match``: the same search on a band's costs;
* ``gcp``: Intille and Bobick's ground control points (``dsi3-gcp``);
* ``bands``: the drivers of the band methods (costs, search, DP for a band of rows).
"""
