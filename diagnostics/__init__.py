"""Research diagnostics of trained policies and recovery modes (not benchmarks: they measure what a policy
believes and does, not speed). Run from the repository root: `python -m diagnostics.<name> --help`."""
