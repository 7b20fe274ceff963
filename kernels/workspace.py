"""Scratch that outlives a run: the buffers a thread's matches use inside and drop.

A fresh array of a few MB is not free on Linux: each of its pages faults in and is
zeroed on first write, about 0.4 ms per MB measured here, and freeing it unmaps it
again.  A cones-sized match (450 x 375, d 0..63) made and dropped about 9 MB of
scratch, which cost a quarter of its time.  So the matches of one thread take their
internal buffers (padded images or census codes, the integer disparity and the right
image's map, the filters' masks and forests) from that thread's Workspace, which keeps
them for the next match, as StereoBM keeps its buffers in its matcher object.  What a
match returns is fresh; kept small, it stays in glibc's heap from call to call: a raw
tsukuba match that also made and dropped its padded images, integer map, masks and a
map of zero confidences faulted in about 500 pages a call, a third of its time, since
glibc gave the heap's top back to the system after each.

Rules that keep this safe:
- a kernel's result holds no workspace buffer: a caller that wants an output without a
  fresh array lends one it owns (``into``, see :func:`output`), and keeps it from
  leaving the call itself;
- a thread uses only its own workspace (:func:`for_this_thread`), so concurrent matches
  never share a buffer;
- a role names one buffer, and an array taken for a role is valid until the next request
  for that role: callers take them for arrays that never leave the call;
- a workspace keeps no buffer over LARGEST bytes and at most LIMIT bytes in all;
  other requests get fresh arrays.  A large buffer's page faults cost little beside the
  work done on it (its match searches as many disparities per pixel as a small one's),
  and keeping it would hold memory after the match and raise the peak of the stages
  after its own (the census codes, kept through the filters, raised the peak of a
  2880 x 1988 match from 293 to 348 MB).  Kept, they saved no time measurable there.
  A semi-global match's slabs are the exception (SLAB_LARGEST): little work is done
  on each of their bytes.
"""

import math
import threading

import numpy as np

# What one thread keeps between matches: the scratch of a 1080p pair's census match
# save its codes.
LARGEST = 8 << 20
LIMIT = 64 << 20
# A semi-global match's slabs (its costs and its sums over the paths, kernels/sgm.py)
# are the exception: kept up to this many bytes each, beside LIMIT (:meth:`Workspace.slab`).
# Their work per byte is a few additions, so faulting them in was not little beside
# it: a 640 x 480 d 0..63 stream frame's two 39 MB slabs took 13% of its time, as
# fresh arrays, on a Zen 4 core.  SGBM keeps its buffer in its matcher object too.
# Kept, a slab is held through the filters after it: slabs of up to 128 MB raised the
# peak of `csw match` at 1920 x 1080 d 0..255 by 108 MB (369 to 477 MB); up to 64 MB (a
# KITTI frame's 60 MB are kept, and that pair's band slabs of 63.98), it is unchanged.
SLAB_LARGEST = 64 << 20
# What a kept bound call holds a pixel, at most: a census call's padded image and codes, the
# speckle filter's forest, and the last outputs its bound calls still point at.
CALL_BYTES = 16


class Workspace:
    """Buffers kept between runs, one per role."""

    def __init__(self, limit=LIMIT, largest=LARGEST):
        self.limit, self.largest = limit, largest
        self._held = {}  # role -> uint8 (n,) buffer
        self._slabs = {}  # role -> uint8 (n,) buffer: see slab()
        self._kept = {}  # role -> (key, object): see keep()

    def held(self):
        """Bytes kept."""
        return sum(buffer.size for buffer in self._held.values())

    def release(self):
        """Keep nothing (arrays already taken stay valid: they hold their buffers)."""
        self._held.clear()
        self._slabs.clear()
        self._kept.clear()

    def empty(self, role, shape, dtype):
        """An uninitialised array of ``shape`` and ``dtype`` in the buffer kept for
        ``role`` (grown as needed), or a fresh array when keeping it would pass the
        limits.  It is valid until the next request for ``role``."""
        return self._take(self._held, role, shape, dtype,
                          lambda n: n <= self.largest and self.held() + n <= self.limit)

    def slab(self, role, shape, dtype):
        """As :meth:`empty`, for a semi-global match's slabs: kept up to SLAB_LARGEST bytes
        each, outside LIMIT and :meth:`held`."""
        return self._take(self._slabs, role, shape, dtype, lambda n: n <= SLAB_LARGEST)

    @staticmethod
    def _take(store, role, shape, dtype, keeps):
        """A view of ``store[role]`` (role -> uint8 buffer), grown as needed; a fresh
        array where keeps(bytes) says no."""
        dtype = np.dtype(dtype)
        nbytes = math.prod(shape) * dtype.itemsize
        buffer = store.get(role)
        if buffer is None or buffer.size < nbytes:
            store.pop(role, None)  # dropped before its successor is made
            if not keeps(nbytes):
                return np.empty(shape, dtype)
            # numpy aligns its buffers for every dtype, so the views below are aligned.
            buffer = store[role] = np.empty(nbytes, np.uint8)
        return buffer[:nbytes].view(dtype).reshape(shape)

    def keeps_calls(self, pixels):
        """Whether runs on images of ``pixels`` pixels keep their bound calls here: up to LARGEST
        bytes at CALL_BYTES a pixel (a bound call keeps its scratch and, bound, its last
        outputs), so about half a megapixel: the frames whose matches take a few
        milliseconds, where making the calls again cost up to a fifth of the time."""
        return pixels * CALL_BYTES <= self.largest

    def kept(self, role, key):
        """The object kept for ``role`` (:meth:`keep`) when it was kept under ``key``,
        else None."""
        held = self._kept.get(role)
        return held[1] if held is not None and held[0] == key else None

    def kept_or_made(self, role, key, make):
        """The object kept for ``role`` under ``key``, or ``make()`` kept in its place."""
        thing = self.kept(role, key)
        return self.keep(role, key, make()) if thing is None else thing

    def keep(self, role, key, thing):
        """Keep ``thing`` for ``role`` under ``key`` (replacing what the role held) and
        return it: a kernel's bound call for the next runs like this one (kernels/fast.py).
        Bound calls are kept only for small images (:meth:`keeps_calls`), so they are not counted
        in the limits."""
        self._kept[role] = (key, thing)
        return thing


def empty(workspace, role, shape, dtype):
    """``workspace.empty(role, shape, dtype)``, or a fresh array without a workspace."""
    if workspace is None:
        return np.empty(shape, dtype)
    return workspace.empty(role, shape, dtype)


def slab(workspace, role, shape, dtype):
    """``workspace.slab(role, shape, dtype)``, or a fresh array without a workspace."""
    if workspace is None:
        return np.empty(shape, dtype)
    return workspace.slab(role, shape, dtype)


def output(into, role, shape, dtype):
    """An output of a kernel: the caller's own array ``into[role]`` (checked: C-contiguous,
    of ``shape`` and ``dtype``), else a fresh one.  Results hold only outputs, never a
    workspace's scratch, so a result stays valid whatever runs next."""
    array = (into or {}).get(role)
    if array is None:
        return np.empty(shape, dtype)
    if array.shape != tuple(shape) or array.dtype != dtype or not array.flags.c_contiguous:
        raise ValueError(f"the {role} output must be C-contiguous {np.dtype(dtype)} "
                         f"{tuple(shape)}, got {array.dtype} {array.shape}")
    return array


_LOCAL = threading.local()


def for_this_thread():
    """The calling thread's workspace."""
    workspace = getattr(_LOCAL, "workspace", None)
    if workspace is None:
        workspace = _LOCAL.workspace = Workspace()
    return workspace
