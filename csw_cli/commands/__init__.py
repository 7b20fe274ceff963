"""The commands, one module each: parse, call the csw library, print."""
