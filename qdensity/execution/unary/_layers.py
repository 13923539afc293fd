"""Vectorised kernels of the unary engine: gates grouped into layers of disjoint rotations.

Gates that touch disjoint qubit pairs commute, so a circuit's Givens rotations can be applied
one *layer* at a time, each layer a handful of numpy operations on all its pairs at once
(``Z[I], Z[J] = c Z[I] - s Z[J], s Z[I] + c Z[J]``). The schedule is as-soon-as-possible: a
gate goes into the layer after the last one that touched either of its qubits, which keeps the
order of every pair of gates that share a qubit, so the product of rotations is unchanged.
Interpreter overhead is paid per layer (``~depth``) instead of per gate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__: list[str] = []


@dataclass(frozen=True)
class Layer:
    """One layer of disjoint rotations: gate ids, their qubit pairs, parameter indices."""

    gates: np.ndarray  # (L,) gate ids in circuit order
    first: np.ndarray  # (L,)
    second: np.ndarray  # (L,)
    pidx: np.ndarray  # (L,) parameter index, -1 for fixed angles
    coefficient: np.ndarray  # (L,)
    trainable: np.ndarray | None  # positions (into the layer) of gates with pidx >= 0
    unique: bool  # parameter indices of the trainable gates are distinct
    rows: np.ndarray  # (2L,) first then second: one gather / scatter per layer


def schedule(num_qubits: int, first: np.ndarray, second: np.ndarray, pidx: np.ndarray,
             coefficient: np.ndarray) -> list[Layer]:
    """ASAP layers of disjoint gates (order of gates sharing a qubit preserved)."""
    num_gates = int(first.size)
    level = np.empty(num_gates, dtype=np.intp)
    last = [0] * num_qubits
    fl, sl = first.tolist(), second.tolist()
    for g in range(num_gates):
        i, j = fl[g], sl[g]
        lv = max(last[i], last[j])
        level[g] = lv
        last[i] = last[j] = lv + 1
    order = np.argsort(level, kind="stable")
    bounds = np.searchsorted(level[order], np.arange(int(level.max(initial=-1)) + 2))
    layers = []
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        ids = order[a:b]
        p = pidx[ids]
        tr = np.flatnonzero(p >= 0)
        ptr = p[tr]
        layers.append(Layer(
            gates=ids, first=first[ids], second=second[ids], pidx=p,
            coefficient=coefficient[ids],
            trainable=None if tr.size == ids.size else tr,
            unique=bool(np.unique(ptr).size == ptr.size),
            rows=np.concatenate([first[ids], second[ids]]),
        ))
    return layers


def _cos_sin(layer: Layer, angles: np.ndarray):
    """``C = [c; c]`` and ``S = [-s; s]``, shaped (2L, 1) for shared angles or (2L, B)."""
    a = angles[layer.gates]
    if a.ndim == 1:
        a = a[:, None]
    c, s = np.cos(a), np.sin(a)
    return np.concatenate([c, c]), np.concatenate([-s, s])


def _swap(W: np.ndarray) -> np.ndarray:
    """Rows ``[second; first]`` of a gathered ``[first; second]`` block."""
    half = W.shape[0] // 2
    return np.concatenate([W[half:], W[:half]])


def rotate(Z: np.ndarray, layers: list[Layer], angles: np.ndarray) -> None:
    """Apply every layer in order to the rows of ``Z`` (n, B), in place.

    Per layer: ``W = Z[rows]`` (``[z_i; z_j]``), ``Z[rows] = C W + S swap(W)``, which is
    ``z_i -> c z_i - s z_j``, ``z_j -> s z_i + c z_j`` on every pair at once.
    """
    for layer in layers:
        C, S = _cos_sin(layer, angles)
        W = Z[layer.rows]
        new = np.multiply(W, C)
        new += S * _swap(W)
        Z[layer.rows] = new


def backward(Y: np.ndarray, G: np.ndarray, layers: list[Layer], angles: np.ndarray,
             num_parameters: int, per_example: bool) -> np.ndarray:
    """Reverse pass from outputs ``Y`` and output gradients ``G`` (both (n, B), overwritten).

    Per gate ``dL/dtheta = g_j u_i - g_i u_j``; activations and gradients are then rotated
    back by ``-theta``. Returns the parameter gradient ``(P, B)`` when ``per_example`` else
    ``(P,)`` summed over the batch (no ``(P, B)`` array is allocated then). ``G`` ends as
    ``dL/dX`` (columns).
    """
    B = Y.shape[1]
    if per_example:
        grad = np.zeros((num_parameters, B))
    else:
        per_gate = np.zeros(sum(layer.gates.size for layer in layers))
        gate_ids = []
    for layer in reversed(layers):
        C, S = _cos_sin(layer, angles)
        L = layer.gates.size
        U, Gt = Y[layer.rows], G[layer.rows]
        if layer.trainable is None or layer.trainable.size:
            tr = slice(None) if layer.trainable is None else layer.trainable
            ui, uj, gi, gj = U[:L][tr], U[L:][tr], Gt[:L][tr], Gt[L:][tr]
            coef = layer.coefficient[tr]
            if per_example:
                d = gj * ui
                d -= gi * uj
                p = layer.pidx[tr]
                if layer.unique:
                    grad[p] += coef[:, None] * d
                else:
                    np.add.at(grad, p, coef[:, None] * d)
            else:
                ids = layer.gates[tr]
                per_gate[ids] = coef * (np.einsum("lb,lb->l", gj, ui)
                                        - np.einsum("lb,lb->l", gi, uj))
                gate_ids.append(ids)
        # undo the rotation (transpose = inverse: C W - S swap(W)) on activations and gradients
        new = np.multiply(U, C)
        new -= S * _swap(U)
        Y[layer.rows] = new
        new = np.multiply(Gt, C)
        new -= S * _swap(Gt)
        G[layer.rows] = new
    if per_example:
        return grad
    out = np.zeros(num_parameters)
    if gate_ids:
        ids = np.concatenate(gate_ids)
        return out + np.bincount(_pidx_of(layers, ids), weights=per_gate[ids],
                                 minlength=num_parameters)
    return out


def _pidx_of(layers: list[Layer], ids: np.ndarray) -> np.ndarray:
    table = np.empty(sum(layer.gates.size for layer in layers), dtype=np.intp)
    for layer in layers:
        table[layer.gates] = layer.pidx
    return table[ids]


def check_gate_list(num_qubits, pairs, parameter_index, coefficient, offset, num_parameters):
    """Checked arrays of :meth:`UnaryCircuit.from_gates` (see there)."""
    n = int(num_qubits)
    if n < 1:
        raise ValueError(f"num_qubits must be a positive int, got {num_qubits!r}")
    arr = np.asarray(pairs, dtype=np.intp)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"pairs must have shape (G, 2), got {arr.shape}")
    if arr.size and (arr.min() < 0 or arr.max() >= n or np.any(arr[:, 0] == arr[:, 1])):
        raise ValueError(f"pairs must be two different qubits in [0, {n}) each")
    g = arr.shape[0]
    pidx = (np.arange(g, dtype=np.intp) if parameter_index is None
            else np.asarray(parameter_index, dtype=np.intp))
    coef = np.ones(g) if coefficient is None else np.asarray(coefficient, dtype=float)
    off = np.zeros(g) if offset is None else np.asarray(offset, dtype=float)
    for name, a in (("parameter_index", pidx), ("coefficient", coef), ("offset", off)):
        if a.shape != (g,):
            raise ValueError(f"{name} must have shape ({g},), got {a.shape}")
    p = int(pidx.max(initial=-1)) + 1 if num_parameters is None else int(num_parameters)
    if pidx.size and (pidx.min() < -1 or pidx.max() >= p):
        raise ValueError(
            f"parameter_index must lie in [-1, {p}), got {pidx.min()}..{pidx.max()}"
        )
    coef = np.where(pidx >= 0, coef, 0.0)
    return (n, np.ascontiguousarray(arr[:, 0]), np.ascontiguousarray(arr[:, 1]), pidx, coef,
            off, p)
