"""One pair matched: the Matcher (matcher), what it does before the first row (setup),
the stages around the kernels, each one record (stages), run in order (pipeline), and
the disparity range, given, from a calibration or found from the pair, decided once
(disparity_range).  A pair of files in and its outputs written is csw.scale.files,
above both ways of matching it (whole, here; in stripes, csw.scale.tiled)."""
