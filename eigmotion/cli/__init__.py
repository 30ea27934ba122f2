"""The ``eigmotion`` command line: :mod:`eigmotion.cli.main` and one module per sub-command."""
