"""Closed-loop evaluation on LeRobot's rollout machinery, with the paper's subtask metrics."""
