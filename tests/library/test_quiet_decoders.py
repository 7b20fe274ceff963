"""csw.io.images.quiet_decoders: tifffile's and Pillow's own messages hidden while csw
reads a file with them (csw says what is wrong in one line), and the process's warnings
filters as they were once the reads end, however the reads of threads overlap."""

import logging
import warnings

from csw.io.images import quiet_decoders


def test_overlapping_reads_leave_the_warnings_filters_as_they_were():
    """Reads in two threads that overlap, the first to start ending first: each with a
    catch_warnings of its own, the second put back the first's filters as it ended,
    and they stayed for the rest of the process."""
    before = list(warnings.filters)
    for first_ends_first in (True, False):
        a, b = quiet_decoders(), quiet_decoders()
        a.__enter__()
        b.__enter__()
        (a if first_ends_first else b).__exit__(None, None, None)
        assert warnings.filters != before  # the other read is still under way
        (b if first_ends_first else a).__exit__(None, None, None)
        assert warnings.filters == before


def test_records_and_warnings_are_hidden_during_a_read_and_shown_after(capsys, recwarn):
    def record(message):  # from a module's logger, as Pillow's plugins log
        return logging.LogRecord("PIL.SomePlugin", logging.ERROR, "x.py", 1, message,
                                 None, None)

    def warn(message):
        warnings.warn_explicit(message, UserWarning, "x.py", 1, module="PIL.Image")

    with quiet_decoders():
        logging.lastResort.handle(record("record hidden"))  # where nothing is configured
        warn("warning hidden")
    logging.lastResort.handle(record("record shown"))
    warn("warning shown")
    err = capsys.readouterr().err
    assert "record hidden" not in err and "record shown" in err
    assert [str(w.message) for w in recwarn] == ["warning shown"]
