"""The paper's settings and its TABLE II (Huynh, Ross, Devlin, Thai: "Constrained Sliding
Window Correspondence Algorithm for Fast Stereo Vision")."""

WINDOW = 9

# Scene -> (dmax at the paper's image size, {cost: tau}).  The 2006 scenes were full size
# (about 1300 x 1110) with d 0..150; TABLE II has only SAD for them.
SETTINGS = {
    "Tsukuba": (16, {"sad": 410, "ssd": 360, "shd": 32}),
    "Wood": (150, {"sad": 670}),
    "Baby": (150, {"sad": 540}),
    "Bowling": (150, {"sad": 1340}),
}

# (scene, cost, csw) -> (error rate %, time reduced % for CSW rows, seconds).
TABLE2 = {
    ("Tsukuba", "sad", False): (11.45, None, 4.5172),
    ("Tsukuba", "sad", True): (10.77, 45.37, 2.4591),
    ("Tsukuba", "ssd", False): (11.08, None, 4.5220),
    ("Tsukuba", "ssd", True): (11.77, 28.98, 3.1997),
    ("Tsukuba", "shd", False): (15.34, None, 21.2262),
    ("Tsukuba", "shd", True): (15.33, 8.61, 19.3995),
    ("Wood", "sad", False): (9.50, None, 514.1873),
    ("Wood", "sad", True): (8.59, 29.84, 360.7466),
    ("Baby", "sad", False): (27.72, None, 455.6641),
    ("Baby", "sad", True): (26.73, 34.58, 298.0912),
    ("Bowling", "sad", False): (9.30, None, 490.3123),
    ("Bowling", "sad", True): (9.07, 24.09, 372.1723),
}


def preset(dataset):
    """(dmax, {cost: tau}) of the paper for a registry Dataset, scaled to its size, or
    None when the paper did not use the scene."""
    if dataset is None or dataset.paper not in SETTINGS:
        return None
    dmax, taus = SETTINGS[dataset.paper]
    if dataset.paper == "Tsukuba":
        return dmax, taus
    return round(dmax * dataset.size_factor), taus
