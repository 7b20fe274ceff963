"""The camera's side: calibrations (calibration), depth maps and point clouds (geometry)."""
