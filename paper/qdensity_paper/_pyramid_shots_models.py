"""The hybrid PyTorch models of ``pyramid-shots`` (paper Fig. 11a; needs the torch extra).

``pixels -> Linear(d, n) -> ReLU (+ offset) -> unary loader + OrthoQNN -> Linear(n, 10)
-> softmax`` with the OrthoQNN one of: the pyramid (pure), its odd-even density split, or the
compressed odd-even split. Imported only by :mod:`qdensity_paper.pyramid_shots` after
:func:`~qdensity_paper._common.require_torch`.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from qdensity.circuits.ansatze import pyramid
from qdensity.learning.torch import DensityQNNLayer
from qdensity.models.compression import compressed_odd_even
from qdensity.models.decompositions import odd_even
from qdensity.models.density import DensityQNN
from qdensity.models.encoding import Encoding
from qdensity.models.mixtures import SoftmaxMixture

__all__ = ["MODELS", "Offset", "quantum_model", "hybrid", "train_hybrid"]

#: model name -> gradient method whose circuits the shot count uses.
MODELS = {"pure": "shift", "odd_even": "commuting", "compressed": "commuting"}


class Offset(nn.Module):
    """``x + c``: keeps rows after the ReLU away from the all-zero vector, which a unary loader
    cannot load (it encodes ``x / ||x||``)."""

    def __init__(self, c: float = 1e-2):
        super().__init__()
        self.c = float(c)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x + self.c


def quantum_model(kind: str, n: int, seed: int) -> DensityQNN:
    """The OrthoQNN of one of :data:`MODELS` on ``n`` qubits (unary probabilities read out)."""
    enc = Encoding.unary(n)
    if kind == "pure":
        return DensityQNN([pyramid(n)], encoding=enc, readout="unary_probabilities", seed=seed)
    dec = odd_even(pyramid(n)) if kind == "odd_even" else compressed_odd_even(pyramid(n))
    return DensityQNN(dec.sub_unitaries, SoftmaxMixture(dec.num_subunitaries), encoding=enc,
                      readout="unary_probabilities", seed=seed)


def hybrid(qnn: DensityQNN, num_inputs: int, num_classes: int, seed: int) -> nn.Sequential:
    """Linear -> ReLU -> offset -> density QNN layer (exact unary engine) -> Linear, float64;
    the classical layers are initialised from ``seed`` (equal for every model of a seed)."""
    torch.manual_seed(seed)
    n = qnn.num_qubits
    pre = nn.Linear(num_inputs, n, dtype=torch.float64)
    post = nn.Linear(n, num_classes, dtype=torch.float64)
    return nn.Sequential(pre, nn.ReLU(), Offset(), DensityQNNLayer(qnn), post)


def train_hybrid(net: nn.Sequential, data, *, epochs: int, batch_size: int, learning_rate: float,
                 shots_per_row: int, evals_per_epoch: int, seed: int) -> dict:
    """Adam on cross entropy; test accuracy ``evals_per_epoch`` times per epoch.

    Returns
    -------
    dict
        ``epoch`` (fractional), ``shots`` (cumulative, ``shots_per_row`` per training row) and
        ``accuracy`` (exact test accuracy) at each evaluation; ``initial``: the test accuracy
        before training.
    """
    X_tr, X_te, y_tr, y_te = (torch.as_tensor(np.asarray(a)) for a in data)
    X_tr, X_te = X_tr.to(torch.float64), X_te.to(torch.float64)
    opt = torch.optim.Adam(net.parameters(), lr=learning_rate)
    loss_fn = nn.CrossEntropyLoss()
    gen = torch.Generator().manual_seed(seed)
    steps = -(-len(y_tr) // batch_size)
    marks = set(np.linspace(0, steps, evals_per_epoch + 1).round().astype(int)[1:].tolist())
    spent = 0

    def accuracy() -> float:
        with torch.no_grad():
            return float((net(X_te).argmax(dim=1) == y_te).double().mean())

    log: dict = {"epoch": [], "shots": [], "accuracy": [], "initial": accuracy()}
    for epoch in range(epochs):
        order = torch.randperm(len(y_tr), generator=gen)
        for step in range(steps):
            idx = order[step * batch_size:(step + 1) * batch_size]
            opt.zero_grad()
            loss_fn(net(X_tr[idx]), y_tr[idx]).backward()
            opt.step()
            spent += shots_per_row * len(idx)
            if step + 1 in marks:
                log["epoch"].append(epoch + (step + 1) / steps)
                log["shots"].append(spent)
                log["accuracy"].append(accuracy())
    return log
