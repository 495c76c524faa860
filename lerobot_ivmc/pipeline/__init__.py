"""The study pipeline: presets, stages run through the project's own commands, resumable, and results."""
