"""Models of the ``moe`` experiment (Supp. H, Fig. 15): the decompositions compared, the
hybrid PyTorch classifier of Fig. 11a with a pure, density or mixture-of-experts quantum layer,
and one training run of it under one set of the paper's hyperparameters."""

from __future__ import annotations

import numpy as np

from qdensity.circuits.ansatze import butterfly, pyramid
from qdensity.models.compression import compressed_odd_even
from qdensity.models.decompositions import by_moments, odd_even

__all__ = ["DECOMPOSITIONS", "VARIANTS", "source_of", "sub_unitaries",
           "build_classifier", "train_classifier"]

#: Decompositions compared (Fig. 15b, c, d) and the circuit each is cut from.
DECOMPOSITIONS = ("butterfly", "odd_even", "compressed")
#: Models per decomposition: the pure source circuit, the density QNN with a trainable
#: data-independent alpha, and the two gates of Supp. H.2 eq. 28 ("MoE", "MoE*").
VARIANTS = ("pure", "density", "moe", "moe_gelu")


def source_of(decomposition: str, num_qubits: int):
    """The circuit a decomposition is cut from: butterfly or pyramid on ``num_qubits``."""
    if decomposition not in DECOMPOSITIONS:
        raise ValueError(f"decomposition must be one of {DECOMPOSITIONS}, got {decomposition!r}")
    return butterfly(num_qubits) if decomposition == "butterfly" else pyramid(num_qubits)


def sub_unitaries(decomposition: str, num_qubits: int) -> list:
    """The sub-unitaries of ``decomposition`` (butterfly by layers: ``log2 n`` of them)."""
    src = source_of(decomposition, num_qubits)
    if decomposition == "butterfly":
        return by_moments(src).sub_unitaries
    if decomposition == "odd_even":
        return odd_even(src).sub_unitaries
    return compressed_odd_even(src).sub_unitaries


def build_classifier(decomposition: str, variant: str, num_inputs: int, num_qubits: int,
                     num_classes: int, seed: int):
    """Fig. 11a's hybrid model: ``Linear(d -> n)``, ReLU (+0.01, so that no row is all-zero for
    the unary loader), unary loader and quantum layer (probabilities of the ``n`` unary
    outcomes), ``Linear(n -> classes)``; float64.

    Returns
    -------
    (torch.nn.Sequential, DensityQNNLayer)
    """
    import torch
    from torch import nn

    from qdensity.learning.torch import DensityQNNLayer, MoEGate
    from qdensity.models import DensityQNN, Encoding
    from qdensity.models.mixtures import SoftmaxMixture

    if variant not in VARIANTS:
        raise ValueError(f"variant must be one of {VARIANTS}, got {variant!r}")
    torch.manual_seed(seed)
    subs = ([source_of(decomposition, num_qubits)] if variant == "pure"
            else sub_unitaries(decomposition, num_qubits))
    k = len(subs)
    mixture = SoftmaxMixture(k) if variant != "pure" else None
    qnn = DensityQNN(subs, mixture, encoding=Encoding.unary(num_qubits),
                     readout="unary_probabilities", seed=seed)
    gate = None
    if variant in ("moe", "moe_gelu"):
        gate = MoEGate(num_qubits, k, activation="gelu" if variant == "moe_gelu" else None)
    layer = DensityQNNLayer(qnn, gate=gate)

    class _Offset(nn.Module):
        def forward(self, x):
            return x + 1e-2

    model = nn.Sequential(nn.Linear(num_inputs, num_qubits, dtype=torch.float64), nn.ReLU(),
                          _Offset(), layer, nn.Linear(num_qubits, num_classes,
                                                      dtype=torch.float64))
    return model, layer


def train_classifier(model, data, params: dict, epochs: int, seed: int) -> dict:
    """Train ``model`` under one hyperparameter set of the paper's space; test accuracy after
    every epoch.

    Parameters
    ----------
    model : torch.nn.Module
    data : tuple
        ``(X_train, y_train, X_val, y_val, X_test, y_test)`` numpy arrays.
    params : dict
        ``batch_size``, ``learning_rate``, ``optimizer`` (adam, sgd, rmsprop), ``l2`` (weight
        decay: ``l2 / 2 ||w||^2`` added to the loss).
    epochs : int
    seed : int
        Batch order.

    Returns
    -------
    dict
        ``test_by_epoch`` (list), ``test_accuracy``, ``val_accuracy`` (after the last epoch).
    """
    import torch
    from torch import nn

    X_tr, y_tr, X_va, y_va, X_te, y_te = (torch.as_tensor(a) for a in data)
    opt_cls = {"adam": torch.optim.Adam, "sgd": torch.optim.SGD,
               "rmsprop": torch.optim.RMSprop}[params["optimizer"]]
    opt = opt_cls(model.parameters(), lr=float(params["learning_rate"]),
                  weight_decay=float(params["l2"]))
    gen = torch.Generator().manual_seed(int(seed))
    bs = int(params["batch_size"])

    def accuracy(X, y) -> float:
        with torch.no_grad():
            return float((model(X).argmax(dim=1) == y).double().mean())

    test = []
    for _ in range(int(epochs)):
        order = torch.randperm(len(y_tr), generator=gen)
        for start in range(0, len(order), bs):
            idx = order[start:start + bs]
            opt.zero_grad()
            loss = nn.functional.cross_entropy(model(X_tr[idx]), y_tr[idx])
            loss.backward()
            opt.step()
        test.append(accuracy(X_te, y_te))
    if not np.all(np.isfinite(test)):
        raise FloatingPointError("training diverged")
    return {"test_by_epoch": test, "test_accuracy": test[-1],
            "val_accuracy": accuracy(X_va, y_va)}
