"""The three tasks of the paper, one small module each."""
