"""Plots: figures drawn from results on disk (matplotlib, Agg canvas)."""
