"""``python -m cfopt`` is the ``cfopt`` command."""

import sys

from cfopt.cli import main

if __name__ == "__main__":
    sys.exit(main())
