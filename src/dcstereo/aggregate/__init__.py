"""Aggregation across scanlines: the semi-global paths of ``sgm`` (Hirschmueller 2008).

* ``sgm``: the path passes over a cost volume, the winner-take-all choice with its
  sub-pixel fit, and the left-right check;
* :mod:`.cross`: cross-based support regions (ADCensus) and the costs averaged over them
  (``sgm``'s ``aggregation``, before the paths).
"""
