"""Seeded procedural rooms of AI2-THOR's four kinds, with their furniture and the objects they hold.

A world is built in four passes, each driven by ``catalog.json`` and the shared ontology:
1. ``floor``: a floor plan, the union of 1-3 axis-aligned rectangles of 0.25 m cells (rect, L, T or U),
   turned and mirrored at random;
2. ``furniture``: entry by entry, each by a named placement strategy (against a wall, in a corner, beside or
   in front of another piece, on top of one, in the middle of the room, or an assembly from ``pieces`` such
   as a kitchen counter run with cabinets, drawers, sink and stove); after every floor-standing piece the
   reachable floor must stay one piece and everything placed so far must stay reachable;
3. ``objects``: small objects, each into a receptacle the ontology allows (on a top surface, inside an
   openable or a basin, or hanging from a holder), some in closed openables, some dirty, some filled;
4. ``objects``: the agent on a random reachable cell, facing away from some task-relevant object.
``generate`` runs the passes on a ``builder``; the result must pass ``harness.world.invariants.check_world``,
and an attempt that fails any pass is redrawn with the next sub-seed, so a seed always gives the same world.
"""
