"""The ``chronofuse`` command line: a thin layer over library calls."""
