"""``python -m cfopt`` is the ``cfopt`` command."""

from cfopt.cli import entry

if __name__ == "__main__":
    entry()
