"""Neural parts (planner, goal transformer, depth and segmentation) and their training code."""
