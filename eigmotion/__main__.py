"""``python -m eigmotion``: the command line."""

import sys

from eigmotion.cli.main import main

sys.exit(main())
