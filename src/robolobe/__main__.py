"""``python -m robolobe``: the ``robolobe`` command (it exits with the command's status)."""

from robolobe.cli.main import main

main()
