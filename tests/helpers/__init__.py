"""Helpers shared by the test folders (`tests/` is on pytest's `pythonpath`): `policies` (configs, batches,
the tiny expert dataset), `clis` (the short env of the end-to-end runs, running the plugin's commands) and
`checkpoints` (the tiny bvmc fixtures, registered in `tests/conftest.py`)."""
