"""One pair matched: the Matcher (matcher), what it does before the first row (setup),
the stages around the kernels, each one record (stages), run in order (pipeline), the
disparity range, given, from a calibration or found from the pair (disparity_range),
and a pair of files in, its outputs written (files)."""
