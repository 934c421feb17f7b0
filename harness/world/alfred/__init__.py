"""Worlds built from an ALFRED trajectory and its AI2-THOR floor plan (``data`` reads both).

The agent's grid is ALFRED's: floor cells are centred on the floor plan's reachable points, so the
trajectory's ``init_action`` (and every pose of its expert plan) lands on a cell centre. Around them:

1. **Receptacles** (``receptacles``, fitted together by ``resolve``) from ``layouts/FloorPlanN-openable.json``
   (plus any receptacle type the floor plan does not list but the trajectory's plan uses, at the plan's
   position), each a box at the position its AI2-THOR id encodes, sized from the catalog, turned to face the
   walkway, and kept AGENT_RADIUS_M from every reachable point, since a reachable point is where the agent's
   capsule fits (moved back first, shrunk if that is not enough, set in front of ALFRED's interaction pose if
   nothing is left). Surfaces grow to cover the objects the trajectory rests on them and take their height
   from those objects; counters get extra segments where objects rest at counter height over nothing
   (AI2-THOR's counters are L-shaped single objects); drawers and cabinets under a surface stack from the
   floor to its underside; sinks and bathtubs become basin (the ``Sink|...|SinkBasin`` id ALFRED lists) plus
   deck, and sinks get a Faucet; upper units are pushed back onto the wall. Overlaps are cut from the later
   piece (or shared, or the piece moves); fronts are brought up to the walkway; anything left hanging stands
   on what is below it.
2. **Fixtures** (``fixtures``) the floor plan lists (``FloorPlanN-objects.json``) without positions: stove
   burners on a counter with a knob each on its front, toaster and coffee machine on a counter, desk lamp on a
   desk, side table or dresser, television on its stand, floor lamp, toilet and garbage can on the floor,
   light switch, towel holders and toilet-paper hanger on walls. Each goes where the trajectory's plan acts on
   one (``plan.high_pddl`` coordinates), else near the objects that hint at it, else to the first free spot of
   a fixed order, so every ALFRED task stays solvable. Objects ALFRED leaves on the floor join them.
3. **The room** (``room``): those cells plus every cell under a piece, holes closed. A cell the agent could
   stand on that ALFRED's grid does not list and nothing stands on leaves the floor (the wall comes up to the
   walkway, or a pillar stands where AI2-THOR has furniture the data does not place; in kitchens that
   furniture is counter, so such pillars are counter-height CounterTop blocks), so the reachable grid stays
   the floor plan's; floor this cuts off from the walkway is joined back by the fewest cells.
4. **Objects** (``objects``) from ``scene.object_poses`` (type = objectName before '_', id = AI2-THOR's id for
   the pose's position), each into or onto the accepting receptacle (the ontology) whose holding volume is
   nearest its ALFRED position, at the free spot nearest that position
   (``harness.sim.physics.resting_center``); inside closed openables they stay closed. ``object_toggles`` set
   isToggled; ``dirty_and_empty`` makes dishes dirty and containers empty (ALFRED's meaning), else everything
   is clean and empty.
5. **The agent** (``room.start_pose``) at ``init_action``: (x, z), rotation as yaw, horizon.

Listed reachable points in pieces the agent cannot walk between are joined by a corridor of at most
MAX_BRIDGE_CELLS cells or dropped; a start point off the listed grid is joined to it. ``AlfredWorldReport``
(``build``) lists those departures from the floor plan and anything that found no place. ``pieces`` holds the
boxes under construction and the geometry rules every stage shares; ``grid`` the walkway.
"""
