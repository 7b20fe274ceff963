"""A calibrated stereo rig, read from the files people have (:func:`read_rig`): both
cameras' intrinsics and distortion, the rotation R and translation T from the left
camera to the right (X_right = R X_left + T, OpenCV's convention), the image size, and
the rectification (R1, R2, P1, P2) where the file gives it.

Formats, found from the content:
  OpenCV FileStorage (YAML, either header, or XML), as the stereo calibration sample
      writes it: M1 D1 M2 D2 (intrinsics.yml) and R T [R1 R2 P1 P2 Q] (extrinsics.yml),
      in one file or two; the image size from "width"/"height" or "image_size"/"imageSize"
      when present, else given.
  ROS camera_info YAML, one file per camera (left first), as ROS's stereo calibrator
      writes them: R and T follow from the rectification and the right projection
      matrix (Tx = -fx B).
  KITTI raw calib_cam_to_cam.txt: cameras 02 and 03 (S K D R T, S_rect R_rect P_rect).
  Kalibr camchain YAML: cam0, cam1 (intrinsics [fu fv pu pv], distortion_model radtan or
      equidistant, distortion_coeffs, resolution, T_cn_cnm1).
"""

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .rectification import coefficients

# Lengths csw knows, in metres: a rig's, a calibration's and every output's units.
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "um": 1e-6, "km": 1000.0, "in": 0.0254,
         "ft": 0.3048}

MODELS = ("plumb_bob", "rational_polynomial", "equidistant")
LARGEST = 1e12  # a focal length in pixels, a baseline in micrometres: far below this


@dataclass(frozen=True, eq=False)
class Rig:
    """A stereo rig (see the module's docstring).  k1, k2: float64 (3, 3); d1, d2:
    float64 distortion vectors; r (3, 3), t (3,): left to right; size: (width, height);
    model: "plumb_bob" (radtan, 4-5 coefficients), "rational_polynomial" (8) or
    "equidistant" (fisheye, k1..k4); rectification: (R1, R2, P1, P2) as the file gives
    them, or None; units: of T where the format says them, else None; paths: the files
    it was read from."""

    k1: np.ndarray
    d1: np.ndarray
    k2: np.ndarray
    d2: np.ndarray
    r: np.ndarray
    t: np.ndarray
    size: tuple
    model: str = "plumb_bob"
    rectification: tuple | None = None
    units: str | None = None
    source: str = "a rig"
    paths: tuple = ()  # the files it was read from: inputs no output may replace

    def __post_init__(self):
        checks = [("k1", (3, 3)), ("k2", (3, 3)), ("r", (3, 3)), ("t", (3,))]
        for name, shape in checks:
            value = np.asarray(getattr(self, name), np.float64)
            if value.shape != shape:
                raise ValueError(f"{self.source}: {name} must be {shape}, got {value.shape}")
            if not np.isfinite(value).all():
                raise ValueError(f"{self.source}: {name} holds a NaN or an infinity")
            if np.abs(value).max() > LARGEST:  # no camera's: and its products overflow
                raise ValueError(f"{self.source}: {name} holds {np.abs(value).max():g}, "
                                 "too large for a camera's calibration")
        for k in (self.k1, self.k2):
            if abs(np.linalg.det(k)) < 1e-12 or k[0, 0] <= 0 or k[1, 1] <= 0:
                raise ValueError(f"{self.source}: a camera matrix is singular or has a "
                                 "focal length <= 0")
        if abs(np.linalg.det(self.r) - 1) > 1e-3:
            raise ValueError(f"{self.source}: R is not a rotation (its determinant is "
                             f"{np.linalg.det(self.r):.4g})")
        if not np.linalg.norm(self.t) > 0:
            raise ValueError(f"{self.source}: the translation T is zero: no baseline")
        if abs(self.t[1]) > abs(self.t[0]):
            raise ValueError(f"{self.source}: a vertical rig (|Ty| > |Tx|) is not supported; "
                             "rotate the images a quarter turn first")
        if self.model not in MODELS:
            raise ValueError(f"{self.source}: unknown distortion model {self.model!r}; "
                             f"csw reads {', '.join(MODELS)}")
        for d in (self.d1, self.d2):
            if not np.isfinite(np.asarray(d, np.float64)).all():
                raise ValueError(f"{self.source}: a distortion vector holds a NaN or an "
                                 "infinity")
            if self.model == "equidistant":
                if np.asarray(d).size != 4:
                    raise ValueError(f"{self.source}: a fisheye (equidistant) camera has 4 "
                                     "coefficients")
            else:
                try:
                    coefficients(d)
                except ValueError as exc:
                    raise ValueError(f"{self.source}: {exc}") from None
        if not (len(self.size) == 2 and all(isinstance(n, int) and n > 0 for n in self.size)):
            raise ValueError(f"{self.source}: the image size must be two whole numbers > 0")

    def check_size(self, size, what="the left image"):
        """ValueError unless ``size`` (width, height), an image's as its header gives it,
        is the rig's: checked before any map is built for the rig's size."""
        if tuple(size) != tuple(self.size):
            raise ValueError(f"{self.source}: the rig is for {self.size[0]}x"
                             f"{self.size[1]} images but {what} is {size[0]}x{size[1]}")

    @property
    def baseline(self):
        return float(np.linalg.norm(self.t))


def read_rig(*paths, size=None):
    """The Rig in ``paths`` (one file, or two: OpenCV's intrinsics and extrinsics, or
    ROS's left and right camera_info), its format found from the content.  size: (width,
    height) for a format that doesn't hold it.  ValueError, naming the file and what is
    missing or wrong, otherwise."""
    if not 1 <= len(paths) <= 2:
        raise ValueError("give the rig as one file, or two (OpenCV intrinsics and "
                         "extrinsics, or ROS left and right camera_info)")
    from dataclasses import replace

    from ..io.safety import read_small

    texts = [read_small(path, "a rig calibration file").decode(errors="replace")
             for path in paths]
    names = " and ".join(str(p) for p in paths)
    try:
        with np.errstate(all="ignore"):  # huge values are refused by Rig, not warned of
            rig = _read(texts, names, len(paths), size)
    except (OverflowError, TypeError) as exc:  # a size of .inf, a list where a number is
        raise ValueError(f"{names}: a value is not a number csw can use ({exc})") from None
    return replace(rig, paths=tuple(Path(p) for p in paths))


def _read(texts, names, count, size):
    """The Rig in the files' ``texts``, its format found from the content."""
    joined = "\n".join(texts)
    if "camera_matrix" in joined and "projection_matrix" in joined:
        if count != 2:
            raise ValueError(f"{names}: a ROS camera_info holds one camera; give the left "
                             "and the right one")
        return _ros(texts, names)
    if re.search(r"^[^\S\n]*cam1\s*:", joined, re.MULTILINE) and "T_cn_cnm1" in joined:
        return _kalibr(joined, names)
    if re.search(r"^[^\S\n]*P_rect_03\s*:", joined, re.MULTILINE) and "K_02" in joined:
        return _kitti(joined, names)
    if re.search(r"\b[MD][12]\b", joined):
        return _opencv(joined, names, size)
    raise ValueError(f"{names}: not a rig calibration csw reads (OpenCV M1 D1 M2 D2 R T, "
                     "ROS camera_info, KITTI calib_cam_to_cam.txt, Kalibr camchain)")


def _numbers(text, source, key):
    values = []
    for token in re.split(r"[\s,\[\]]+", text.strip()):
        if token:
            try:
                values.append(float(token.lower().replace(".nan", "nan")
                                    .replace(".inf", "inf")))
            except ValueError:
                raise ValueError(f"{source}: {key} holds {token!r}, not a number") from None
    return np.array(values, np.float64)


def _opencv_matrix(text, key, source, shape=None, required=True):
    """A FileStorage matrix by name, YAML or XML; None when absent and not required."""
    node = _yaml_node(text, key)
    if node is None:  # XML, or absent
        found = re.search(rf"<{key}\b[^>]*>.*?<data>(.*?)</data>", text, re.DOTALL)
    else:  # a plain list, or an !!opencv-matrix with its data
        found = re.match(r"\s*\[(.*?)\]", node, re.DOTALL) or \
            re.search(r"\bdata\s*:\s*\[(.*?)\]", node, re.DOTALL)
    if not found:
        if required:
            raise ValueError(f"{source}: no {key} matrix")
        return None
    values = _numbers(found.group(1), source, key)
    if shape is not None and values.size != math.prod(shape):
        raise ValueError(f"{source}: {key} must hold {math.prod(shape)} numbers, got "
                         f"{values.size}")
    return values.reshape(shape) if shape is not None else values


def _yaml_node(text, key):
    """The text of the YAML node ``key`` (a regular expression) names: what follows its
    colon, and the lines after it indented deeper than the key; None when absent.  A
    node is read only within itself: a plain list (``R: [1, 0, 0, ...]``) is that list,
    never the next matrix's data."""
    found = re.search(rf"^([ \t]*)(?:{key})[ \t]*:(.*)$", text, re.MULTILINE)
    if not found:
        return None
    lines, indent = [found.group(2)], len(found.group(1))
    for line in text[found.end():].splitlines()[1:]:
        if line.strip() and len(line) - len(line.lstrip()) <= indent:
            break
        lines.append(line)
    return "\n".join(lines)


def _opencv_size(text, source, size):
    for keys in (("width", "height"), ("image_width", "image_height")):
        found = [re.search(rf"^[^\S\n]*{k}\s*:\s*(\d+)", text, re.MULTILINE) or
                 re.search(rf"<{k}>\s*(\d+)\s*</{k}>", text) for k in keys]
        if all(found):
            return _whole_size([f.group(1) for f in found], source)
    pair = _opencv_matrix(text, "(?:image_size|imageSize)", source, required=False)
    if pair is None:
        pair = re.search(r"^[^\S\n]*(?:image_size|imageSize)\s*:\s*\[\s*(\d+)\s*,\s*(\d+)",
                         text, re.MULTILINE)
        pair = [pair.group(1), pair.group(2)] if pair else None
    if pair is not None and len(pair) == 2:
        return _whole_size(pair, source)
    if size is None:
        raise ValueError(f"{source}: the file doesn't say the image size; give it (the "
                         "raw images' size is used when matching)")
    return _whole_size(size, source)


def _whole_size(values, source):
    """(width, height) from two whole numbers in 1..2**31 - 1 as a file gives them (a
    YAML value may be anything: a string, a list, .inf, 10**24); ValueError otherwise."""
    try:
        numbers = [float(v) for v in values]
    except (TypeError, ValueError, OverflowError):
        numbers = []
    if len(numbers) != 2 or not all(1 <= n < 2**31 and abs(n - round(n)) < 1e-6
                                    for n in numbers):
        raise ValueError(f"{source}: the image size must be two whole numbers in 1.."
                         f"{2**31 - 1}, got {str(values)[:40]}")
    return tuple(round(n) for n in numbers)


def _opencv(text, source, size):
    k1, k2 = (_opencv_matrix(text, key, source, (3, 3)) for key in ("M1", "M2"))
    d1, d2 = (_opencv_matrix(text, key, source) for key in ("D1", "D2"))
    r = _opencv_matrix(text, "R", source)
    r = r.reshape(3, 3) if r.size == 9 else _rotation(r, source)
    t = _opencv_matrix(text, "T", source, (3,))
    given = [_opencv_matrix(text, key, source, shape, required=False)
             for key, shape in (("R1", (3, 3)), ("R2", (3, 3)), ("P1", (3, 4)),
                                ("P2", (3, 4)))]
    rectification = tuple(given) if all(g is not None for g in given) else None
    model = "rational_polynomial" if max(d1.size, d2.size) >= 8 else "plumb_bob"
    model = _opencv_word(text, "distortion_model") or model
    units = _opencv_word(text, "units")

    if units not in (None, "none", *UNITS):
        raise ValueError(f"{source}: unknown units {units!r}; csw reads {', '.join(UNITS)}")
    return Rig(k1, d1, k2, d2, r, t, _opencv_size(text, source, size), model,
               rectification, None if units == "none" else units, source)


def _opencv_word(text, key):
    """A FileStorage string by name (csw calibrate's units and distortion_model), or
    None when absent."""
    found = re.search(rf"^{key}\s*:\s*[\"']?(\w+)", text, re.MULTILINE) or \
        re.search(rf"<{key}>\s*[\"']?(\w+)", text)
    return found.group(1) if found else None


def _rotation(vector, source):
    from .rectification import rodrigues

    if vector.size != 3:
        raise ValueError(f"{source}: R must be a 3x3 matrix or a rotation vector")
    return rodrigues(vector)


MAX_YAML_DEPTH = 32  # a rig file nests three or four levels


def _yaml(text, source):
    """A YAML document, read safely: no aliases (a kilobyte of them, each naming the last
    several times, expands to gigabytes) and no deeper nesting than MAX_YAML_DEPTH (the
    composer recurses), each refused in one line."""
    import yaml

    class Loader(yaml.SafeLoader):
        depth = 0

        def compose_node(self, parent, index):
            if self.check_event(yaml.AliasEvent):
                raise ValueError(f"{source}: YAML aliases (*name) are not read in a rig file")
            self.depth += 1
            if self.depth > MAX_YAML_DEPTH:
                raise ValueError(f"{source}: the YAML nests deeper than {MAX_YAML_DEPTH} "
                                 "levels; not a rig file")
            try:
                return super().compose_node(parent, index)
            finally:
                self.depth -= 1

        def construct_yaml_int(self, node):
            # Python refuses to read a whole number of over 4,300 digits, in words
            # about sys.set_int_max_str_digits that name no file.
            try:
                return super().construct_yaml_int(node)
            except ValueError:
                raise ValueError(f"{source}: line {node.start_mark.line + 1} holds a "
                                 f"number of {len(node.value):,} characters; not a rig "
                                 "file") from None

    Loader.add_constructor("tag:yaml.org,2002:int", Loader.construct_yaml_int)

    text = re.sub(r"^%YAML[: ]1\.\d\s*$", "", text, flags=re.MULTILINE)
    try:
        return yaml.load(text, Loader)  # noqa: S506 (a SafeLoader)
    except yaml.YAMLError as exc:
        raise ValueError(f"{source}: not readable YAML "
                         f"({str(exc).splitlines()[0]})") from None


def _field(record, key, source, shape=None):
    try:
        value = record[key]
        if isinstance(value, dict):
            value = value["data"]
        values = np.array(value, np.float64).ravel()
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"{source}: no {key} (or not numbers)") from None
    if shape is not None:
        if values.size != math.prod(shape):
            raise ValueError(f"{source}: {key} must hold {math.prod(shape)} numbers")
        values = values.reshape(shape)
    return values


ROS_MODELS = {"plumb_bob": "plumb_bob", "rational_polynomial": "rational_polynomial",
              "equidistant": "equidistant", "fisheye": "equidistant"}


def _ros(texts, source):
    return rig_from_camera_info([_yaml(text, source) for text in texts], source)


def rig_from_camera_info(cams, source):
    """The Rig of a left and a right camera_info, each a mapping with the keys of ROS's
    YAML files (camera_matrix, distortion_coefficients, rectification_matrix,
    projection_matrix: lists or {data: [...]}; image_width, image_height,
    distortion_model): read from files, or from a log's CameraInfo messages."""
    if not all(isinstance(c, dict) for c in cams):
        raise ValueError(f"{source}: a camera_info must be a YAML mapping")
    k1, k2 = (_field(c, "camera_matrix", source, (3, 3)) for c in cams)
    d1, d2 = (_field(c, "distortion_coefficients", source) for c in cams)
    r1, r2 = (_field(c, "rectification_matrix", source, (3, 3)) for c in cams)
    p1, p2 = (_field(c, "projection_matrix", source, (3, 4)) for c in cams)
    sizes = {_whole_size((c.get("image_width"), c.get("image_height")), source)
             for c in cams}
    if len(sizes) != 1:
        raise ValueError(f"{source}: the left and right camera_info give different sizes")
    models = {ROS_MODELS.get(str(c.get("distortion_model", "plumb_bob"))) for c in cams}
    if None in models or len(models) != 1:
        raise ValueError(f"{source}: unknown or mixed distortion models; csw reads "
                         f"{', '.join(ROS_MODELS)}")
    model = models.pop()
    if model == "plumb_bob" and max(d1.size, d2.size) >= 8:
        model = "rational_polynomial"
    if p1[0, 3] != 0 and p2[0, 3] == 0:
        raise ValueError(f"{source}: the first camera_info is the right camera's (its "
                         "projection matrix holds the baseline); give the left one first")
    # Rectified frames: R1 X_left = X_rect, R2 X_right = X_rect - (B, 0, 0), with
    # P2[0, 3] = -fx B: so R = R2^T R1 and T = R2^T (P2[0, 3] / fx, 0, 0).
    shift = np.array([p2[0, 3] / p2[0, 0], p2[1, 3] / p2[1, 1], 0.0])
    r = r2.T @ r1
    t = r2.T @ shift
    return Rig(k1, d1, k2, d2, r, t, sizes.pop(), model, (r1, r2, p1, p2), None, source)


def key_values(text, separator):
    """{key: value} of a calibration text's ``key<separator>value`` lines (KITTI's
    ``P2: ...``, Middlebury's ``baseline=...``), the value without its outer blanks, a
    later key over an earlier one.  A line's indent is its own blanks: ``\\s`` would run
    on across empty lines, and from each of a hostile file's many blank lines (the
    square of its size)."""
    return dict(re.findall(rf"^[^\S\n]*(\w+)\s*{separator}\s*(.*\S)[^\S\n]*$", text,
                           re.MULTILINE))


def _kitti(text, source):
    rows = key_values(text, ":")

    def matrix(key, shape):
        if key not in rows:
            raise ValueError(f"{source}: no {key}")
        values = _numbers(rows[key], source, key)
        if values.size != math.prod(shape):
            raise ValueError(f"{source}: {key} must hold {math.prod(shape)} numbers")
        return values.reshape(shape)

    k1, k2 = matrix("K_02", (3, 3)), matrix("K_03", (3, 3))
    d1, d2 = matrix("D_02", (5,)), matrix("D_03", (5,))
    # R_0i, T_0i take camera 0's frame to camera i's: left to right is R3 R2^T.
    r2_, r3_ = matrix("R_02", (3, 3)), matrix("R_03", (3, 3))
    t2_, t3_ = matrix("T_02", (3,)), matrix("T_03", (3,))
    r = r3_ @ r2_.T
    t = t3_ - r @ t2_
    width, height = _whole_size(matrix("S_02", (2,)), source)
    rect = None
    if all(k in rows for k in ("R_rect_02", "R_rect_03", "P_rect_02", "P_rect_03")):
        # R_rect_0i: camera i's rectifying rotation (raw to rectified frame).
        rect = _relative((matrix("R_rect_02", (3, 3)), matrix("R_rect_03", (3, 3)),
                          matrix("P_rect_02", (3, 4)), matrix("P_rect_03", (3, 4))))
    return Rig(k1, d1, k2, d2, r, t, (width, height), "plumb_bob", rect, "m", source)


def _relative(rect):
    """KITTI's P_rect matrices hold both cameras' offsets from camera 0: make P1 the
    left's own (no offset) and P2's offset the baseline between the two."""
    r1, r2, p1, p2 = (np.array(m, np.float64) for m in rect)
    p2 = p2.copy()
    p2[:, 3] -= p1[:, 3]
    p1 = p1.copy()
    p1[:, 3] = 0.0
    return r1, r2, p1, p2


def _kalibr(text, source):
    chain = _yaml(text, source)
    try:
        cams = [chain["cam0"], chain["cam1"]]
    except (KeyError, TypeError):
        raise ValueError(f"{source}: a Kalibr camchain needs cam0 and cam1") from None
    ks, ds, models = [], [], []
    for cam in cams:
        fu, fv, pu, pv = _field(cam, "intrinsics", source, (4,))
        ks.append(np.array([[fu, 0, pu], [0, fv, pv], [0, 0, 1]]))
        ds.append(_field(cam, "distortion_coeffs", source))
        models.append({"radtan": "plumb_bob", "equidistant": "equidistant"}.get(
            str(cam.get("distortion_model"))))
    if None in models or models[0] != models[1]:
        raise ValueError(f"{source}: unknown or mixed distortion models (radtan, "
                         "equidistant)")
    transform = _field(cams[1], "T_cn_cnm1", source, (4, 4))  # cam0 -> cam1
    sizes = {_whole_size(cam.get("resolution", ()), source) for cam in cams}
    if len(sizes) != 1:
        raise ValueError(f"{source}: cam0 and cam1 need one resolution [width, height]")
    return Rig(ks[0], ds[0], ks[1], ds[1], transform[:3, :3], transform[:3, 3],
               sizes.pop(), models[0], None, "m", source)
