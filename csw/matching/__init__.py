"""One pair matched: the Matcher (matcher), what it does before the first row (setup),
the stages around the kernels (pipeline), the range found from the pair (autorange),
and a pair of files in, its outputs written (files)."""
