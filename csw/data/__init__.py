"""Data: the dataset registry and its downloads, benchmark folders in their published
layouts, and the synthetic scene."""
