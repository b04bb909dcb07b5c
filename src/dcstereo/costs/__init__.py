"""Matching costs: a pixel pair's dissimilarity, summed over a window.

* ``window``: the paper's windowed SAD (eq. 4) and Birchfield-Tomasi's
  sampling-insensitive dissimilarity, one scanline at a time;
* ``band``: the same costs for ``BAND_ROWS`` rows in lockstep (the band methods);
* ``census``: the census transform, its Hamming cost and the truncated colour
  difference, and the cost volume of ``sgm`` (averaged over a box); ``census_sparse``:
  the census with its samples two or more pixels apart (``census_step``); ``smoothing``:
  the Gaussian smoothing of the intensity before the census (``census_smoothing``).
"""
