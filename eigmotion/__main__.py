"""``python -m eigmotion``: the command line."""

from eigmotion.cli.main import entry

entry()
