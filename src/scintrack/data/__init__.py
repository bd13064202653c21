"""Datasets: synthetic generators' outputs, versions and the dataset manifest."""
