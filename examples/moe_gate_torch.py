"""A mixture-of-experts gate written in PyTorch for a density QNN (Supp. H, "MoE*").

The density model's K sub-unitaries are the experts; the gate ``alpha(x)`` that weighs them
is any torch module mapping the input (B, d) to (B, K) probabilities -- here a small MLP with a
GELU, trained end to end with the quantum angles. The task is a toy one where the best expert
depends on the input: points on the unit sphere labelled by the sign of their first coordinate.
Run::

    python examples/moe_gate_torch.py [--quick]
"""

from __future__ import annotations

import argparse

import torch
from torch import nn

from qdensity.circuits.ansatze import round_robin
from qdensity.learning.torch import DensityQNNLayer
from qdensity.models import DensityQNN, Encoding
from qdensity.models.decompositions import by_moments


def gate(num_features: int, num_experts: int) -> nn.Module:
    """``alpha(x) = softmax(W2 GELU(W1 x + b1) + b2)``."""
    return nn.Sequential(nn.Linear(num_features, 16, dtype=torch.float64), nn.GELU(),
                         nn.Linear(16, num_experts, dtype=torch.float64), nn.Softmax(dim=-1))


def main(steps: int = 150, num_qubits: int = 4, seed: int = 0, verbose: bool = True):
    """Train; returns ``(first loss, last loss, accuracy, gate weight grad norm)``."""
    torch.manual_seed(seed)
    dec = by_moments(round_robin(num_qubits))
    qnn = DensityQNN(dec.sub_unitaries, encoding=Encoding.unary(num_qubits),
                     readout="unary_probabilities", seed=seed)
    layer = DensityQNNLayer(qnn, gate=gate(num_qubits, dec.num_subunitaries))
    head = nn.Linear(num_qubits, 2, dtype=torch.float64)
    model = nn.Sequential(layer, head)
    X = torch.randn(128, num_qubits, dtype=torch.float64)
    y = (X[:, 0] > 0).long()
    opt = torch.optim.Adam(model.parameters(), lr=0.05)
    losses = []
    grad_norm = 0.0
    for step in range(steps):
        opt.zero_grad()
        loss = nn.functional.cross_entropy(model(X), y)
        loss.backward()
        grad_norm = float(layer.gate[0].weight.grad.norm())
        opt.step()
        losses.append(loss.item())
        if verbose and step % 25 == 0:
            print(f"step {step:>3}  loss {losses[-1]:.4f}")
    with torch.no_grad():
        acc = float((model(X).argmax(dim=1) == y).double().mean())
        alpha = layer.mixture_weights(X[:3])
    if verbose:
        print(f"accuracy {acc:.3f}; alpha(x) for three inputs:\n{alpha.numpy().round(3)}")
    return losses[0], losses[-1], acc, grad_norm


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="30 steps")
    main(steps=30 if parser.parse_args().quick else 150)
