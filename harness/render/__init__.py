"""What the agent sees: the ``camera`` convention (AI2-THOR's poses, rays and pixels), the ``geometry`` of
every object as drawn boxes, its ``appearance`` (materials, states, light) and ``palette`` (one colour per
type), and the ``renderer`` that turns a world into RGB, depth and instance frames."""
