"""Figures, built on matplotlib.figure.Figure (no pyplot, no GUI backend)."""
