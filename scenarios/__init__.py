"""The examples of the prioritized-IK and irteus manuals as scenario scripts, installed
as ``pik_mj.scenarios``.

Each module ``pik_mj.scenarios.<name>`` is a script (``python -m
pik_mj.scenarios.<name>``, or ``pik-mj run <name>``) with a ``main(argv)`` and a
``run(recorder, ...) -> pik_mj.scenario.ScenarioResult``; the first line of its
docstring describes it. :data:`SCENARIOS` is the registry: the names, in the
order ``pik-mj list`` shows them.
"""

SCENARIOS: list[str] = [
    "three_dof_reach",
    "cocktail_shaker",
    "fullbody_reach",
    "fullbody_external_force",
    "kettle",
    "wall_contact",
    "obstacle_reach",
    "walk_forward",
    "walk_go_pos",
]

DEFAULT = "fullbody_reach"
"""What ``pik-mj run`` runs without a name."""
