"""``python -m pik_mj.sweep``: the ``pik-mj sweep`` command."""

from .cli import main

raise SystemExit(main())
