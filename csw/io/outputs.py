"""A pair's outputs, checked and written in one place, whatever brought the pair: one
pair (csw.match_files), a batch's pair, a striped pair (csw.match_tiled) or a stream's
frame (csw.scale.stream).

A run names each output by its role (ROLES: the map, its preview, the confidence ...).
:class:`PairOutputs` checks them all before any work (csw.io.safety: the suffix each
role allows, folders, inputs, links; the free space; the map format's range), then
takes a ``write_to(tmp)`` per role as the pair's results come, and writes them together
(csw.io.atomic: all or none, never a partial file).  It lives in csw.io, under the
matching and the scale layers that use it: it knows files, not how a map is made; a
3-D output's writer (csw.camera.geometry.writers) is handed to it like any other.
"""

import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from . import safety
from .atomic import atomic_write_all, temporary_prefix
from .formats import (
    array_blocks,
    check_map_range,
    disparity_writer,
    float_map_writer,
    pfm_writer,
    preview_stripes,
    suffixes,
)

# What each output may be, by role (csw.io.formats.suffixes); a map's ("output") is any
# map format, a confidence map's a float one.
ROLES = {"output": suffixes("map"), "confidence": suffixes("confidence"),
         "preview": suffixes("picture"), "cost_map": suffixes("costs"),
         "plot": suffixes("picture"), "depth": suffixes("depth"),
         "cloud": suffixes("cloud"), "depth_preview": suffixes("picture"),
         "rectified_left": suffixes("picture")}

# An upper bound of each output's size, per pixel: float maps, a 16-bit PNG map, RGB
# pictures, a PLY's point (3 floats and 3 bytes).  A striped match keeps temporary
# stores of about 8 more beside its map.
BYTES_PER_PIXEL = {"output": 4, "confidence": 4, "preview": 3, "cost_map": 4, "depth": 4,
                   "cloud": 15, "depth_preview": 3, "rectified_left": 3}
STRIPE_STORES_PER_PIXEL = 8


def role_suffixes(role):
    """The suffixes an output of ``role`` may have (ROLES)."""
    return ROLES[role]


def check_range_of(path, dmin, dmax):
    """An OptionError naming dmax when the map format of ``path`` can't hold
    disparities dmin..dmax (csw.io.formats.check_map_range); a bound "auto" is checked
    when the map is written."""
    try:
        check_map_range(path, dmax, dmin)
    except ValueError as exc:
        raise safety.option_error(str(exc), "dmax") from None


class PairOutputs:
    """One pair's outputs: ``paths`` (role -> path, None for one not asked for).

    >>> outputs = PairOutputs({"output": "d.pfm", "preview": "d.png"}, {"left": "l.png"})
    >>> outputs.check(shape=(480, 640), known_range=(0, 63))   # before any work
    >>> outputs.add_map(disparity); outputs.add_preview(disparity, 0, 63)
    >>> outputs.write()                                          # all or none

    ``allowed``: role -> suffixes, where a caller allows fewer than ROLES (a striped
    map: the stripe formats).  ``written`` lists every path this object has written,
    for its callers' reports (and the tests' spies)."""

    def __init__(self, paths, inputs=None, allowed=None):
        self.paths = {role: Path(path) for role, path in paths.items() if path is not None}
        self.inputs = dict(inputs or {})
        self.allowed = {role: (allowed or {}).get(role) or ROLES[role] for role in self.paths}
        self._staged = []
        self.written = []

    def __contains__(self, role):
        return role in self.paths

    def get(self, role):
        return self.paths.get(role)

    def check(self, shape=None, known_range=None, striped=False):
        """Before any work, every check below: :meth:`check_paths`, :meth:`check_range`
        and, for a pair of ``shape`` (H, W), :meth:`check_space`."""
        self.check_paths()
        self.check_range(known_range)
        if shape is not None:
            self.check_space(shape, striped)

    def check_paths(self):
        """csw.io.safety.check_outputs: suffixes by role, folders that exist and can be
        written, no input overwritten, no two outputs one file, links followed."""
        safety.check_outputs(self.inputs, self.paths, self.allowed)

    def check_targets(self):
        """Only csw.io.safety.check_target for each output (a regular file or nothing
        yet, a zarr store's folder, no input): what csw.match_tiled, called alone on
        arrays or paths, has always asked of its outputs."""
        for role, path in self.paths.items():
            safety.check_target(path, role, folder_ok=path.suffix.lower() == ".zarr")

    def check_range(self, known_range):
        """The map's format holds ``known_range`` (dmin, dmax, a bound not known yet
        "auto": checked when the map is written; None: neither is known)."""
        if known_range is not None and "output" in self.paths:
            check_range_of(self.paths["output"], *known_range)

    def check_space(self, shape, striped=False):
        """The outputs of a pair of ``shape`` (H, W) fit their disks, a ``striped``
        pair's temporary stores counted in (csw.io.safety.check_space)."""
        pixels = shape[0] * shape[1]
        safety.check_space(
            (path, pixels * (BYTES_PER_PIXEL.get(role, 4)
                             + (STRIPE_STORES_PER_PIXEL if striped and role == "output"
                                else 0)))
            for role, path in self.paths.items())

    def add(self, role, write_to):
        """Stage the output of ``role``: ``write_to(tmp)`` writes it (csw.io.formats'
        writers); nothing is written before :meth:`write`."""
        self._staged.append((self.paths[role], write_to))

    def add_map(self, disparity):
        """The disparity map, whole, in its path's format."""
        self.add("output", disparity_writer(self.paths["output"], disparity))

    def add_preview(self, disparity, dmin, dmax):
        """The colour picture of the map over dmin..dmax, with its bar, if a preview was
        asked for: written by the striped maps' writer (csw.io.formats.preview_stripes,
        csw.io.pictures' colours), so that a pair's preview has the same bytes whole,
        in stripes or as a stream's frame."""
        if "preview" in self.paths:
            self.add("preview", preview_stripes(disparity.shape, array_blocks(disparity),
                                                dmax, dmin))

    def add_float_map(self, role, values):
        """A float map of ``role`` (the confidence) in its path's float format, if asked
        for."""
        if role in self.paths:
            self.add(role, float_map_writer(self.paths[role], values))

    def add_cost_map(self, min_cost):
        """The minimum-cost map as PFM, inf where no candidate, if asked for."""
        if "cost_map" in self.paths:
            m = np.where(min_cost >= 0, min_cost, np.inf).astype(np.float32)
            self.add("cost_map", pfm_writer(m))

    def add_items(self, items):
        """(path, write_to) items made elsewhere (csw.camera.geometry.writers), each
        for one of this pair's outputs."""
        known = {path: role for role, path in self.paths.items()}
        for path, write_to in items:
            self.add(known[Path(path)], write_to)

    def write(self):
        """Write every output staged, all or none (csw.io.atomic.atomic_write_all)."""
        staged, self._staged = self._staged, []
        atomic_write_all(staged)
        self.written += [path for path, _ in staged]

    def place_store(self, role, folder):
        """Put the zarr store ``folder`` (written beside the output) at the output of
        ``role``, replacing an earlier store there; the old one goes through a temporary
        name, which the next run removes if this one is killed in between."""
        path = self.paths[role]
        path = Path(os.path.realpath(path)) if path.is_symlink() else path
        old = None
        if path.exists():
            if not (path / "zarr.json").is_file():
                raise ValueError(f"{path} exists and is not a zarr store; csw won't "
                                 "replace it")
            old = Path(tempfile.mkdtemp(prefix=temporary_prefix(path.name), suffix=".tmp",
                                        dir=path.parent))
            os.replace(path, old / "store")
        os.replace(folder, path)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
        self.written.append(self.paths[role])
