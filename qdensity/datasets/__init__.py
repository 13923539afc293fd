"""Datasets of the paper's experiments."""
