"""Episodes: a world, a task, and what the driver is given (dialogue, history) and expected to do."""
