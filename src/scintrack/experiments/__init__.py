"""Scenarios, the Monte Carlo runner and the metrics of the tracking experiments."""
