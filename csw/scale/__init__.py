"""A pair of files (files: whole, or in row stripes when it needs them), and more than
one pair or more than memory can hold: batches (batch) on threads or a Dask cluster
(executor, distributed), pairs matched in row stripes (tiled), and streams of frames
(stream)."""
