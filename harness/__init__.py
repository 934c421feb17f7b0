"""Our household simulator harness: worlds, renderer, actions, tasks, expert, episodes, runner."""
