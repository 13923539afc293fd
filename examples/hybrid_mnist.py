"""The paper's hybrid MNIST-style model in PyTorch (Fig. 11a), on scikit-learn's digits.

    image (64 pixels) -> Linear(64 -> 8) -> ReLU (+ 0.01) -> unary loader + density OrthoQNN
    (round-robin on 8 qubits cut into its 7 moments, softmax mixture) -> Linear(8 -> 10)
    -> softmax (cross entropy)

Every part trains with one torch optimiser: the classical layers by torch, the quantum angles
and mixture logits by the unary engine's exact reverse mode, which also hands the gradient
back to the ReLU/Linear layer before the loader. Run::

    python examples/hybrid_mnist.py              # about a minute on two cores
    python examples/hybrid_mnist.py --quick      # a few seconds (what the test suite runs)
"""

from __future__ import annotations

import argparse

import torch
from sklearn.datasets import load_digits
from sklearn.model_selection import train_test_split
from torch import nn

from qdensity.circuits.ansatze import round_robin
from qdensity.learning.torch import DensityQNNLayer
from qdensity.models import DensityQNN, Encoding
from qdensity.models.decompositions import by_moments
from qdensity.models.mixtures import SoftmaxMixture


class Offset(nn.Module):
    """``x + c``: after the ReLU, keeps every row away from the all-zero vector, which a unary
    loader cannot load (it encodes ``x / ||x||``)."""

    def __init__(self, c: float = 1e-2):
        super().__init__()
        self.c = c

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x + self.c


def build(num_qubits: int = 8, seed: int = 0) -> nn.Module:
    """Linear -> ReLU -> density OrthoQNN -> Linear, all float64."""
    torch.manual_seed(seed)
    dec = by_moments(round_robin(num_qubits))
    qnn = DensityQNN(dec.sub_unitaries, SoftmaxMixture(dec.num_subunitaries),
                     encoding=Encoding.unary(num_qubits), readout="unary_probabilities",
                     seed=seed)
    pre = nn.Linear(64, num_qubits, dtype=torch.float64)
    return nn.Sequential(pre, nn.ReLU(), Offset(), DensityQNNLayer(qnn),
                         nn.Linear(num_qubits, 10, dtype=torch.float64))


def main(epochs: int = 15, samples: int | None = None, seed: int = 0, verbose: bool = True):
    """Train and return ``(first epoch loss, last epoch loss, test accuracy)``."""
    X, y = load_digits(return_X_y=True)
    if samples is not None:
        X, y = X[:samples], y[:samples]
    X = X / 16.0
    X_tr, X_te, y_tr, y_te = train_test_split(X, y, test_size=0.25, random_state=seed)
    X_tr, X_te = torch.tensor(X_tr), torch.tensor(X_te)
    y_tr, y_te = torch.tensor(y_tr), torch.tensor(y_te)
    model = build(seed=seed)
    opt = torch.optim.Adam(model.parameters(), lr=0.02)
    loss_fn = nn.CrossEntropyLoss()
    gen = torch.Generator().manual_seed(seed)
    losses = []
    for epoch in range(epochs):
        order = torch.randperm(len(X_tr), generator=gen)
        total = 0.0
        for start in range(0, len(order), 32):
            idx = order[start:start + 32]
            opt.zero_grad()
            loss = loss_fn(model(X_tr[idx]), y_tr[idx])
            loss.backward()
            opt.step()
            total += loss.item() * len(idx)
        losses.append(total / len(X_tr))
        if verbose:
            print(f"epoch {epoch + 1:>2}  loss {losses[-1]:.4f}")
    with torch.no_grad():
        acc = float((model(X_te).argmax(dim=1) == y_te).double().mean())
    if verbose:
        print(f"test accuracy {acc:.3f} on {len(y_te)} digits")
    return losses[0], losses[-1], acc


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="3 epochs on 300 digits")
    args = parser.parse_args()
    if args.quick:
        main(epochs=3, samples=300)
    else:
        main()
