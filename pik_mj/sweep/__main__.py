"""``python -m pik_mj.sweep``: the ``pik-mj sweep`` command."""

import sys

from pik_mj.sweep.cli import command

raise SystemExit(command(sys.argv[1:]))
