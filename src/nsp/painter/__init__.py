"""The painter (SPEC §5): parameter search for strokes that reproduce a target image."""
