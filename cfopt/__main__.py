"""``python -m cfopt`` is the ``cfopt`` command."""

import sys

from cfopt.cli import main

sys.exit(main())
