"""``python -m pik_mj.sweep``: the ``pik-mj sweep`` command."""

import sys

from pik_mj.cli import main

raise SystemExit(main(["sweep", *sys.argv[1:]]))
