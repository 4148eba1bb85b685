"""``python -m chronofuse ...``: the ``chronofuse`` program, for an environment without its console script."""

from chronofuse.cli.main import main

main()
