"""Labelled results (xarray) and the one table of metrics and variables."""
