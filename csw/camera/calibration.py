"""A rectified pair's calibration, read from what people have: Middlebury's calib.txt,
KITTI's projection matrices, OpenCV's reprojection matrix Q, or values given by hand.

Every source becomes one :class:`Calibration`: the focal length f and principal point
(cx, cy) of the rectified left camera in pixels, the baseline B between the cameras, the
disparity offset doffs (the right principal point's x less the left's) and the units of
B.  Depth is then Z = f B / (d + doffs) in those units, and a pixel (x, y) with disparity
d is the point Q (x, y, d, 1) of OpenCV's reprojection (x right, y down, z forward, in
the left camera's frame).
"""

import functools
import math
import re
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..config.params import OptionError
from ..io import safety
from .rig import UNITS, key_values

MAX_FILE_BYTES = safety.SMALL_FILE_BYTES  # a calibration is a few lines

FLOAT32_TINY = float(np.finfo(np.float32).tiny)
FLOAT32_MAX = 3.4e38



@dataclass(frozen=True)
class Calibration:
    """A rectified pair's geometry.

    focal, cx, cy: the rectified left camera's focal length and principal point (pixels);
        cx, cy None for the image's centre.
    baseline: the distance between the cameras' centres, in ``units``.
    doffs: the disparity offset, the right principal point's x less the left's (pixels):
        Z = focal * baseline / (d + doffs).
    units: the baseline's units ("mm", "m" ...), or None where the source doesn't say.
    width, height: the image size the calibration is for, where the source says it.
    ndisp: the disparities 0..ndisp-1 that bound the scene (Middlebury), or None.
    q: OpenCV's 4x4 reprojection matrix, where that was the source (kept as given, so
        that points equal cv2.reprojectImageTo3D's).
    source: where it came from, for messages and summaries.
    """

    focal: float
    baseline: float
    cx: float | None = None  # None: the image's centre, (W - 1) / 2
    cy: float | None = None
    doffs: float = 0.0
    units: str | None = None
    width: int | None = None
    height: int | None = None
    ndisp: int | None = None
    q: tuple | None = None
    source: str = "given values"

    def __post_init__(self):
        for name in ("focal", "baseline", "cx", "cy", "doffs"):
            value = getattr(self, name)
            if value is None and name in ("cx", "cy"):
                continue
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"{self.source}: {name} must be a finite number, got "
                                 f"{value!r}")
        if self.focal == 0 or self.baseline == 0:
            which = "focal length" if self.focal == 0 else "baseline"
            raise ValueError(f"{self.source}: the {which} is 0, so no depth follows from "
                             "it; check the calibration")
        # Depths are float32: beyond its range every depth would be inf, below its
        # smallest normal number 0 (and Q's 1 / baseline overflows first).
        size = abs(self.focal * self.baseline)
        if not FLOAT32_TINY <= min(size, abs(self.focal), abs(self.baseline)) or \
                not size < FLOAT32_MAX:
            extreme = "large" if size >= FLOAT32_MAX else "small"
            raise ValueError(f"{self.source}: focal length x baseline ({self.focal:g} x "
                             f"{self.baseline:g}) is too {extreme} to give a depth; check "
                             "the calibration")
        if self.units is not None and self.units not in UNITS:
            raise ValueError(f"{self.source}: unknown units {self.units!r}; use "
                             f"{', '.join(UNITS)}")

    def matrix(self, shape=None):
        """OpenCV's reprojection matrix Q (float64 (4, 4)): [X Y Z W] = Q [x y d 1];
        shape (H, W) places a principal point not given at the image's centre."""
        if self.q is not None:
            return np.array(self.q, np.float64)
        height, width = shape if shape is not None else (1, 1)
        cx = (width - 1) / 2 if self.cx is None else self.cx
        cy = (height - 1) / 2 if self.cy is None else self.cy
        return np.array([[1, 0, 0, -cx], [0, 1, 0, -cy], [0, 0, 0, self.focal],
                         [0, 0, 1 / self.baseline, self.doffs / self.baseline]], np.float64)

    def check_size(self, shape):
        """ValueError when the calibration is for another image size than ``shape``."""
        if self.width is not None and self.height is not None and \
                (self.height, self.width) != tuple(shape):
            raise OptionError("calib", f"{self.source} is for {self.width}x{self.height} "
                                       f"images but the disparity map is {shape[1]}x"
                                       f"{shape[0]}; use the calibration of these images")

    def scale_to(self, units):
        """The factor from the calibration's units to ``units`` (1 for None).  A
        calibration that doesn't say its units (an OpenCV Q, values given by hand, where
        depth comes out in the baseline's units) is taken to be in ``units``: name them
        with :meth:`with_units` to convert."""
        if units is None:
            return 1.0
        if units not in UNITS:
            raise OptionError("units", f"unknown units {units!r}; use {', '.join(UNITS)}")
        if self.units is None:
            return 1.0
        factor = UNITS[self.units] / UNITS[units]
        # Depths are float32 (see __post_init__): focal x baseline in the new units too.
        if not abs(self.focal * self.baseline * factor) < FLOAT32_MAX:
            raise OptionError("units", f"{self.source}: in {units}, focal length x baseline "
                                       f"is {abs(self.focal * self.baseline * factor):g}, "
                                       "past what a depth map holds; use a larger unit")
        return factor

    def with_units(self, units):
        """This calibration with its units named (None: as it is): for a source that
        doesn't say them (an OpenCV Q, values given by hand).  OptionError when the source
        says other units."""
        if units is None or units == self.units:
            return self
        if units not in UNITS:
            raise OptionError("calib_units", f"unknown units {units!r}; use "
                                             f"{', '.join(UNITS)}")
        if self.units is not None:
            raise OptionError("calib_units", f"{self.source} says its units are "
                                             f"{self.units}, not {units}; drop the "
                                             "calibration's units (--units converts)")
        return replace(self, units=units)

    def describe(self):
        """One line for summaries: the source, f, B and doffs."""
        units = f" {self.units}" if self.units else ""
        return (f"{self.source} (f {self.focal:g} px, baseline {self.baseline:g}{units}, "
                f"doffs {self.doffs:g})")

    def as_dict(self):
        """The record as plain values (batch summaries)."""
        return {k: getattr(self, k) for k in ("source", "focal", "baseline", "cx", "cy",
                                              "doffs", "units")}


def given(focal, baseline, cx=None, cy=None, doffs=0.0, units=None):
    """A Calibration from values given by hand (the CLI's --focal, --baseline, ...); the
    principal point defaults to the image's centre."""
    def number(value):
        return None if value is None else float(value)

    return Calibration(float(focal), float(baseline), number(cx), number(cy),
                       float(doffs or 0.0), units, source="the values given")


def from_options(calib=None, focal=None, baseline=None, cx=None, cy=None, doffs=None,
                 calib_units=None):
    """The calibration the command line names: a file (``calib``), or values given by
    hand (focal and baseline at least), or None; its units named by ``calib_units`` where
    it doesn't say them.  OptionError for both at once, a half-given set of values, or
    units that contradict the file's."""
    found = _from_options(calib, focal, baseline, cx, cy, doffs)
    if found is None:
        if calib_units is not None:
            raise OptionError("calib_units", "the calibration's units need a calibration "
                                             "(--calib, or --focal and --baseline)")
        return None
    return found.with_units(calib_units)


def _from_options(calib, focal, baseline, cx, cy, doffs):
    values = {"focal": focal, "baseline": baseline, "cx": cx, "cy": cy, "doffs": doffs}
    named = [k for k, v in values.items() if v is not None]
    if calib is not None and named:
        raise OptionError(named[0], "give a calibration file or its values, not both")
    if calib is not None:
        return read_calibration(calib)
    if not named:
        return None
    for key in ("focal", "baseline"):
        if values[key] is None:
            raise OptionError(key, f"values given by hand need the {key} too")
    return given(focal, baseline, cx, cy, doffs)


def read_calibration(path):
    """The Calibration in ``path``, its format found from its content: Middlebury 2014
    calib.txt, KITTI calib (P2/P3 or P_rect_02/P_rect_03), an OpenCV FileStorage
    YAML/XML file with a Q node, or a 4x4 Q in a .npy file.  ValueError (an OptionError
    for "calib"), naming the file and what is missing, when it is none of them."""
    path = Path(path)
    refuse = functools.partial(OptionError, "calib")
    try:
        if path.suffix.lower() == ".npy":
            from ..io.formats import load_npy

            safety.check_small(path, "a calibration file", refuse, MAX_FILE_BYTES)
            return from_q(load_npy(path), str(path))
        text = safety.read_small(path, "a calibration file", refuse, MAX_FILE_BYTES)\
            .decode(errors="replace")
    except OptionError:
        raise
    except OSError as exc:
        raise OptionError("calib", f"{path}: can't read it ({exc.strerror or exc})") from None
    except (ValueError, EOFError) as exc:  # np.load's, for a file that is no .npy array
        reason = str(exc).splitlines()[0][:100] if str(exc) else type(exc).__name__
        raise OptionError("calib", f"{path}: not a readable .npy array ({reason})") from None
    try:
        if re.search(r"^[^\S\n]*cam0\s*=", text, re.MULTILINE):
            return _middlebury(text, str(path))
        # KITTI's rows hold their numbers; an OpenCV rig's P2 (!!opencv-matrix) does not.
        if re.search(r"^[^\S\n]*(P2|P_rect_02)\s*:[^\S\n]*[-+.\d]", text, re.MULTILINE):
            return _kitti(text, str(path))
        if re.search(r"(^[^\S\n]*Q\s*:|<Q[\s>])", text, re.MULTILINE):
            return from_q(_opencv_q(text, str(path)), str(path))
        if re.search(RIG_KEYS, text, re.MULTILINE):
            return _rig(path)
    except OptionError:
        raise
    except (ValueError, OverflowError) as exc:
        raise OptionError("calib", str(exc)) from None
    raise OptionError("calib", f"{path}: not a calibration csw knows (Middlebury calib.txt "
                               "with cam0=..., KITTI calib with P2:/P3: or P_rect_02/03, "
                               "an OpenCV YAML/XML with a Q matrix, a 4x4 .npy, or a rig "
                               "file as --rig takes)")


# What a rig file (csw.read_rig's formats) holds: OpenCV's M1..T, ROS camera_info,
# Kalibr's camchain.
RIG_KEYS = r"\b[MD][12]\b|^[^\S\n]*camera_matrix\s*:|^[^\S\n]*T_cn_cnm1\s*:"


def _rig(path):
    """The calibration of a rig file's pair once rectified (alpha 0, or as the file gives
    R1 R2 P1 P2): what csw rectify's calib.txt would say.  ValueError naming --rig when
    the file is a rig that one file can't give (ROS's two camera_info files, a size not
    stated)."""
    from .rectification import rectification
    from .rig import read_rig

    try:
        rig = read_rig(path)
    except ValueError as exc:
        raise ValueError(f"{exc}; as a rig, give it to --rig (csw match or csw rectify)"
                         ) from None
    _, _, p1, p2 = rectification(rig)
    return replace(rectified_calibration(rig, p1, p2), source=f"{path}, rectified")


def rectified_calibration(rig, p1, p2):
    """The Calibration (csw.depth's, Q's) of a rig's pair rectified by P1, P2."""
    width, height = rig.size
    return Calibration(float(p1[0, 0]), float(-(p2[0, 3] - p1[0, 3]) / p2[0, 0]),
                       float(p1[0, 2]), float(p1[1, 2]), float(p2[0, 2] - p1[0, 2]),
                       rig.units, width, height, source=f"{rig.source}, rectified")


def _numbers(text):
    return [float(v) for v in re.findall(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?", text)]


def _number(text, key, source):
    """A finite number written as ``text`` for ``key``; ValueError naming both."""
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{source}: {key} must be a number, got {text[:40]!r}") from None
    if not math.isfinite(value):
        raise ValueError(f"{source}: {key} must be a finite number, got {text[:40]!r}")
    return value


def _count(text, key, source, low=1, high=10**6):
    """A whole number from low to high written as ``text`` for ``key`` (a size, ndisp)."""
    value = _number(text, key, source)
    if value != int(value) or not low <= value <= high:
        raise ValueError(f"{source}: {key} must be a whole number from {low} to {high}, "
                         f"got {text!r}")
    return int(value)


def _matrix(text, key, source, size):
    """``size`` finite numbers from a matrix's text; ValueError naming the key."""
    numbers = _numbers(text)
    if len(numbers) != size or not all(map(math.isfinite, numbers)):
        raise ValueError(f"{source}: {key} must hold {size} finite numbers, got {text!r}")
    return numbers


def _middlebury(text, source):
    """Middlebury 2014's calib.txt: cam0=[f 0 cx; 0 f cy; 0 0 1], cam1, doffs, baseline
    (mm), width, height, ndisp, ..., and csw rectify's units= (mm, or none)."""
    values = key_values(text, "=")
    missing = [k for k in ("cam0", "baseline") if k not in values]
    if "doffs" not in values and "cam1" not in values:
        missing.append("doffs (or cam1)")
    if missing:
        raise ValueError(f"{source}: a Middlebury calib.txt without {', '.join(missing)}")
    cam0 = _matrix(values["cam0"], "cam0 (a 3x3 matrix [f 0 cx; 0 f cy; 0 0 1])", source, 9)
    doffs = _number(values["doffs"], "doffs", source) if "doffs" in values else \
        _matrix(values["cam1"], "cam1", source, 9)[2] - cam0[2]

    def whole(key):
        return _count(values[key], key, source) if key in values else None

    # The baseline is in mm, or in the units= line csw rectify writes ("none": unknown).
    units = values.get("units", "mm")
    if units != "none" and units not in UNITS:
        raise ValueError(f"{source}: unknown units {units!r}; use {', '.join(UNITS)} or none")
    return Calibration(cam0[0], _number(values["baseline"], "baseline", source), cam0[2],
                       cam0[5], doffs, None if units == "none" else units, whole("width"),
                       whole("height"), whole("ndisp"), source=source)


def _kitti(text, source):
    """KITTI: P2/P3 (the object and stereo benchmarks' calib files) or P_rect_02 and
    P_rect_03 (calib_cam_to_cam.txt), 3x4 projection matrices of the rectified colour
    cameras in metres."""
    rows = key_values(text, ":")
    left = rows.get("P2") or rows.get("P_rect_02")
    right = rows.get("P3") or rows.get("P_rect_03")
    if left is None or right is None:
        raise ValueError(f"{source}: a KITTI calibration without "
                         f"{'P3 (or P_rect_03)' if left else 'P2 (or P_rect_02)'}")
    p2, p3 = (np.array(_matrix(r, key, source, 12), np.float64)
              for r, key in ((left, "P2"), (right, "P3")))
    p2, p3 = p2.reshape(3, 4), p3.reshape(3, 4)
    focal = p2[0, 0]
    if focal == 0:
        raise ValueError(f"{source}: P2's focal length is 0")
    # P = K [I | t] with t = -C: the x offsets give the cameras' centres, in metres.
    baseline = (p2[0, 3] - p3[0, 3]) / focal
    size = re.search(r"^[^\S\n]*S_rect_02\s*:\s*(.*\S)[^\S\n]*$", text, re.MULTILINE)
    width = height = None
    if size:
        found = _numbers(size.group(1))[:2]
        if len(found) != 2:
            raise ValueError(f"{source}: S_rect_02 must hold the width and height")
        width, height = (_count(repr(v), "S_rect_02", source) for v in found)
    return Calibration(float(focal), float(baseline), float(p2[0, 2]), float(p2[1, 2]),
                       float(p3[0, 2] - p2[0, 2]), "m", width, height, source=source)


def _opencv_q(text, source):
    """The Q matrix of an OpenCV FileStorage file, YAML or XML (as cv::FileStorage writes
    stereoRectify's Q)."""
    if "<opencv_storage" in text or text.lstrip().startswith("<?xml"):
        import xml.etree.ElementTree as ET

        try:
            node = ET.fromstring(text).find("Q")
        except ET.ParseError as exc:
            raise ValueError(f"{source}: not readable XML ({exc})") from None
        if node is None or node.find("data") is None:
            raise ValueError(f"{source}: no Q matrix with its data")
        values = _opencv_numbers(node.find("data").text or "", source)
    else:
        # The first data: [...] after the first Q key, each found once (a lazy match
        # from every Q line to the file's end took the square of its size).
        key = re.search(r"^[^\S\n]*Q\s*:", text, re.MULTILINE)
        found = key and re.compile(r"data\s*:\s*\[([^\]]*)\]").search(text, key.end())
        if not found:
            raise ValueError(f"{source}: no Q matrix with its data: [...]")
        values = _opencv_numbers(found.group(1), source)
    if len(values) != 16:
        raise ValueError(f"{source}: Q must be 4x4, got {len(values)} numbers")
    return np.array(values, np.float64).reshape(4, 4)


def _opencv_numbers(text, source):
    """The numbers of a FileStorage matrix's data, as written (YAML's .nan and .inf
    included, so that the error says what is wrong with them)."""
    values = []
    for token in re.split(r"[\s,]+", text.strip()):
        if not token:
            continue
        try:
            values.append(float(token.lower().replace(".nan", "nan").replace(".inf", "inf")))
        except ValueError:
            raise ValueError(f"{source}: Q holds {token!r}, not a number") from None
    if not all(map(math.isfinite, values)):
        raise ValueError(f"{source}: Q must hold finite numbers, got "
                         f"{', '.join(f'{v:g}' for v in values if not math.isfinite(v))}")
    return values


def from_q(q, source="Q"):
    """A Calibration from OpenCV's 4x4 reprojection matrix Q (stereoRectify's):
    f = Q[2,3], cx = -Q[0,3], cy = -Q[1,3], B = 1 / Q[3,2], doffs = Q[3,3] / Q[3,2]."""
    q = np.asarray(q)
    if q.dtype.kind not in "biuf" or q.dtype.names:
        raise OptionError("calib", f"{source}: Q must hold real numbers, got {q.dtype}")
    q = q.astype(np.float64)
    if q.shape != (4, 4) or not np.isfinite(q).all():
        raise OptionError("calib", f"{source}: Q must be a finite 4x4 matrix, got shape "
                                   f"{q.shape}")
    if abs(np.linalg.det(q)) < 1e-12:
        raise OptionError("calib", f"{source}: Q is not invertible (its determinant is 0): "
                                   "no depth follows from it")
    if q[3, 2] == 0:
        raise OptionError("calib", f"{source}: Q[3,2] = -1/Tx is 0: no baseline")
    return Calibration(float(q[2, 3]), float(1 / q[3, 2]), float(-q[0, 3]), float(-q[1, 3]),
                       float(q[3, 3] / q[3, 2]), None, q=tuple(map(tuple, q)), source=source)


def resolve(calib=None, left=None):
    """The calibration a match uses: ``calib`` (a Calibration, or a path to read), else
    the calib.txt beside the left image (Middlebury 2014's layout), else None."""
    if isinstance(calib, Calibration):
        return calib
    if calib is not None:
        return read_calibration(calib)
    found = beside(left)
    return read_calibration(found) if found is not None else None



def beside(image):
    """The calib.txt in the folder of ``image`` (Middlebury 2014's layout), or None."""
    if not isinstance(image, (str, Path)):
        return None
    candidate = Path(image).parent / "calib.txt"
    return candidate if candidate.is_file() else None


__all__ = ["UNITS", "Calibration", "beside", "from_q", "given", "read_calibration",
           "resolve"]
