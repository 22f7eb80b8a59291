"""Sweeps: many cases (hand targets × robots × stacks) solved, checked and held on Ray.

A balanced-reachability map: where can a humanoid put its hand while standing,
and stay standing? :class:`Sweep` defines the cases (a :class:`Grid` or a
:class:`Uniform` random set of task parameters × robots × stacks);
:func:`run_sweep` runs them on Ray (a local instance, or a cluster) into a
Parquet dataset written one batch file at a time, resumable; :mod:`.views`
draws the map (PNG, rerun recording) and prints a summary table.

.. code-block:: python

    from pik_mj.sweep import Grid, Sweep, run_sweep

    sweep = Sweep(Grid({"x": [0.3, 0.5], "y": [-0.2], "z": [0.6, 1.0]}), hold=1.0)
    report = run_sweep(sweep, "out/reach", workers=2)
    print(report.summary())

Modules: :mod:`.spec` (cases), :mod:`.case` (one case on pik_mj's API: the
only module that calls it), :mod:`.driver` (Ray), :mod:`.dataset` (Parquet),
:mod:`.views`, :mod:`.cli`.
"""

from pik_mj.sweep.case import PARAMETERS, STACKS, Worker
from pik_mj.sweep.dataset import RESULT_FIELDS, UNREPEATABLE, VERDICTS, read_rows
from pik_mj.sweep.driver import SweepReport, run_sweep
from pik_mj.sweep.spec import Case, Grid, Sweep, Uniform

__all__ = [
    "PARAMETERS",
    "RESULT_FIELDS",
    "STACKS",
    "UNREPEATABLE",
    "VERDICTS",
    "Case",
    "Grid",
    "Sweep",
    "SweepReport",
    "Uniform",
    "Worker",
    "read_rows",
    "run_sweep",
]
