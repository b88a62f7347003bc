"""The ``atlas`` command line: the only part of atlas-rap that prints."""
