"""The ``csw`` command line: Click commands that parse, call the csw library and print."""
