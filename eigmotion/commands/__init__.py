"""Sub-commands of the ``eigmotion`` command line, one module each."""
