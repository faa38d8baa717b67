"""Experiments that are not a plain training or painting run (the paper's transport-loss studies)."""
