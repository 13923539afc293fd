"""Parameterised sub-unitary families (paper Fig. 3, 4, 9 and Methods)."""

from .hamming import butterfly, pairs_circuit, pyramid, round_robin, round_robin_pairs, x_circuit

__all__ = ["pyramid", "x_circuit", "butterfly", "round_robin", "round_robin_pairs", "pairs_circuit"]
