"""OpenCV-shaped: the :class:`~dcstereo.compat.stereo_dc.StereoDC` matcher, OpenCV's baselines."""
