"""The worlds: ``model`` (``World``, its room, objects and agent), the ``catalog`` they are made from, the
``invariants`` every world passes, the ``splits`` that keep unseen worlds out of training, and the two ways
of building one: ``procedural`` (seeded rooms of AI2-THOR's four kinds) and ``alfred`` (rooms rebuilt from
ALFRED trajectories and floor plans); ``walls`` holds the frames both builders place furniture in."""
