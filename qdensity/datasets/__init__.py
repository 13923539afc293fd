"""Datasets of the paper's experiments: noisy bars and dots (equivariant models, Methods),
Chebyshev targets (data re-uploading, eq. 12, Supp. J), PCA-reduced digits (orthogonal QNNs,
bundled with scikit-learn) and MNIST from the user's own files. Each returns numpy arrays;
none downloads anything."""

from qdensity.datasets.bars_and_dots import bars_and_dots
from qdensity.datasets.chebyshev import chebyshev, chebyshev_dataset, chebyshev_split
from qdensity.datasets.digits import load_digits_features
from qdensity.datasets.mnist import load_mnist, read_idx

__all__ = [
    "bars_and_dots",
    "chebyshev",
    "chebyshev_dataset",
    "chebyshev_split",
    "load_digits_features",
    "load_mnist",
    "read_idx",
]
