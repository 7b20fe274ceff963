"""What a run of many items (a batch's pairs, a stream's frames) reports: each item's
entry (:class:`PairLog`), the summary file written atomically (``write_summary``), and
the signals held while it is written (:class:`signals_held`)."""

import itertools
import json
import os
import tempfile
from array import array
from collections.abc import Sequence
from pathlib import Path

from ..io.atomic import atomic_write

NOTED_KEPT = 20  # notes on pairs (a range cut short...) a batch's report repeats


class PairLog:
    """A batch's summary entries as they come, kept on disk (a temporary file beside the
    summary) with only their offsets, counts and failures in memory: a million-pair
    batch's summary takes a few bytes a pair in this process, not its entries."""

    def __init__(self, folder, total):
        self.handle = tempfile.TemporaryFile(dir=folder if folder.is_dir() else None)
        # Each entry's offset, -1 until it comes; grown as entries come past ``total``
        # (a video's frames, whose count is not known ahead).
        self.offsets = array("q", [-1]) * total
        self.counts = {"ok": 0, "skipped": 0, "failed": 0}
        self.failed = []
        self.noted = []  # (name, note) of the first NOTED_KEPT notes; all are in the summary
        self.notes = 0

    @property
    def done(self):
        return sum(self.counts.values())

    def add(self, index, entry):
        if index >= len(self.offsets):
            self.offsets.extend([-1] * (index + 1 - len(self.offsets)))
        self.offsets[index] = self.handle.seek(0, os.SEEK_END)
        self.handle.write(json.dumps(entry, sort_keys=True, default=str).encode() + b"\n")
        self.counts[entry["status"]] += 1
        if entry["status"] == "failed":
            self.failed.append(entry)
        for note in entry.get("notes", ()):
            self.notes += 1
            if len(self.noted) < NOTED_KEPT:
                self.noted.append((entry["name"], note))

    def lines(self):
        """Each entry's JSON line, in the jobs' order."""
        for offset in self.offsets:
            if offset >= 0:
                self.handle.seek(offset)
                yield self.handle.readline().rstrip(b"\n")

    def close(self):
        self.handle.close()


class SummaryPairs(Sequence):
    """The entries of a summary file, in the jobs' order, read from the file when asked
    for (a batch's report holds no list of them)."""

    def __init__(self, path, count):
        self.path, self.count = Path(path), count

    def __len__(self):
        return self.count

    def __iter__(self):
        with open(self.path, "rb") as handle:
            inside = False
            for line in handle:
                if inside and line.startswith(b"{"):
                    yield json.loads(line.rstrip(b",\n"))
                inside = inside or line.rstrip().endswith(b'"pairs": [')

    def __getitem__(self, index):
        if isinstance(index, slice):
            return list(self)[index]
        index = range(self.count)[index]
        return next(itertools.islice(iter(self), index, None))


def write_summary(path, log, options, interrupted=False, extra=None):
    """Write the JSON summary atomically, one pair a line in the jobs' order, and return
    the report: counts, options, interrupted, failed (the failed pairs' entries), noted
    ((name, note) of the first NOTED_KEPT notes on pairs) and notes (how many), and
    pairs (every entry, read from the summary when asked for); ``extra``: more fields
    for the summary's head (a video's frames a second ...)."""
    head = {"counts": log.counts, "interrupted": interrupted, "options": options,
            **(extra or {})}

    def write(tmp):
        with open(tmp, "wb") as out:
            text = json.dumps(head, indent=2, sort_keys=True, default=str)
            out.write(text[:-2].encode() + b',\n  "pairs": [\n')
            for i, line in enumerate(log.lines()):
                out.write((b",\n" if i else b"") + line)
            out.write(b"\n  ]\n}\n")
    atomic_write(path, write)
    return dict(head, failed=list(log.failed), noted=list(log.noted), notes=log.notes,
                pairs=SummaryPairs(path, log.done))


class signals_held:
    """Within the ``with``, Ctrl-C, SIGTERM and SIGHUP wait: one that comes is acted on
    (by the handler that was in place) when the block ends, so that a frame's outputs
    and its summary entry are written together or not at all.  Outside the main thread,
    where no handler can be set, it does nothing."""

    NAMES = ("SIGINT", "SIGTERM", "SIGHUP")

    def __enter__(self):
        import signal
        import threading

        self.saved, self.caught = {}, []
        if threading.current_thread() is not threading.main_thread():
            return self
        for name in self.NAMES:
            number = getattr(signal, name, None)
            if number is not None:
                self.saved[number] = signal.signal(
                    number, lambda signum, frame: self.caught.append((signum, frame)))
        return self

    def __exit__(self, *exc):
        import signal

        for number, handler in self.saved.items():
            signal.signal(number, handler)
        if self.caught and exc[0] is None:
            signum, frame = self.caught[0]
            handler = self.saved.get(signum)
            if callable(handler):
                handler(signum, frame)  # raises KeyboardInterrupt, or csw's Stopped
            elif handler == signal.SIG_DFL:
                signal.raise_signal(signum)
        return False
