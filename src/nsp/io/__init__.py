"""Stroke files and exports: nsp JSON, the reference implementation's .npz, PNG, SVG, GIF."""
