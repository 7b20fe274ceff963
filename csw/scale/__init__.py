"""More than one pair in memory can hold: batches (batch) on threads or a Dask cluster
(executor, distributed), and pairs matched in row stripes (tiled)."""
