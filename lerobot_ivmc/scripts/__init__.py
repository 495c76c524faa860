"""Command-line entry points (`lerobot-ivmc-*`)."""
