"""Datasets of the paper's experiments: noisy bars and dots (equivariant models, Methods),
Chebyshev targets (data re-uploading, eq. 12, Supp. J) and PCA-reduced digits (orthogonal
QNNs). Each takes ``seed`` and returns numpy arrays; none downloads anything."""

from qdensity.datasets.bars_and_dots import bars_and_dots
from qdensity.datasets.chebyshev import chebyshev_dataset
from qdensity.datasets.digits import load_digits_features

__all__ = ["bars_and_dots", "chebyshev_dataset", "load_digits_features"]
