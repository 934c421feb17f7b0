"""Tasks the harness can pose and check: TEACh's 12 benchmark task types and ALFRED's 7 task types.

- ``teach``: name, describe and check TEACh tasks on a World (``check_task``), counted as TEACh counts
  goal conditions; ``teach_definitions`` and ``teach_checker`` hold the definitions and the counting rules.
- ``alfred``: ALFRED tasks from a trajectory's ``pddl_params`` and their goal conditions (``check_alfred``).
- ``sampling``: task parameters a given world can satisfy, and the object types a task needs.
- ``progress``: the ``GoalReport`` every check returns (counts for SR/GC, words for a commander).

May import ``harness.world`` and ``symbolic``; never ``agent``, ``app`` or ``models``.
"""
