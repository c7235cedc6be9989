"""``python -m cfopt`` is the ``cfopt`` command."""

import sys

try:
    from cfopt.cli import entry
except KeyboardInterrupt:  # Ctrl-C while the command line itself loads
    sys.stderr.write("error: interrupted (SIGINT)\n")
    sys.exit(130)

if __name__ == "__main__":
    entry()
