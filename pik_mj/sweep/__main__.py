"""``python -m pik_mj.sweep``: the ``pik-mj sweep`` command."""

import sys

from pik_mj.sweep.cli import command

if __name__ == "__main__":  # importing the module (autosummary does) runs nothing
    raise SystemExit(command(sys.argv[1:]))
