"""Models and training of the ``equivariant`` experiment (paper Fig. 5, Methods "Equivariant
density QNN"): the three base families of Bowles et al., their second sub-unitaries, and one
training run recorded every few steps.

=============== ================================ ========================================
family          base U_1 (observable)            second sub-unitary U_2
=============== ================================ ========================================
``xx``          commuting XX, weight <= 3        the same circuit with Y generators (YY)
                (``sum_i Z_i``)
``noncommuting``  Bowles et al. Fig. 5c, layers    an independent copy (own init, own
                (``sum_i Z_i``)                  training): "non-comm-2"
``qcnn``        QCNN (``Z`` on the readout)      an independent copy: "QCNN-2"
=============== ================================ ========================================
"""

from __future__ import annotations

import copy

import numpy as np
from qiskit.circuit import QuantumCircuit
from qiskit.quantum_info import SparsePauliOp

from qdensity.circuits.ansatze import (
    equivariant_commuting,
    equivariant_noncommuting,
    equivariant_observable,
    qcnn,
    qcnn_readout_qubit,
)
from qdensity.learning.estimators import QNNClassifier, QNNRegressor
from qdensity.models.density import DensityQNN, Encoding

__all__ = ["FAMILIES", "LABELS", "sub_unitary", "observable", "single_model", "train_recorded"]

#: Base model families (Bowles et al.'s three non-trivial models).
FAMILIES = ("xx", "noncommuting", "qcnn")

#: Curve names of each family: (base model, density model).
LABELS = {"xx": ("XX", "XX+YY density"),
          "noncommuting": ("non-comm", "non-comm + non-comm-2 density"),
          "qcnn": ("QCNN", "QCNN + QCNN-2 density")}


def sub_unitary(family: str, num_qubits: int, second: bool, *, max_weight: int = 3,
                layers: int = 4) -> QuantumCircuit:
    """The base circuit ``U_1`` of ``family`` (``second=False``) or its ``U_2``.

    Parameters
    ----------
    family : {"xx", "noncommuting", "qcnn"}
    num_qubits : int
    second : bool
        ``U_2``: the YY circuit for ``"xx"``, an independently parameterised copy otherwise.
    max_weight : int
        Largest generator weight of the XX / YY circuits (3 in the paper, Fig. 4a).
    layers : int
        Layers of the non-commuting circuit (4 in Bowles et al.'s code).

    Returns
    -------
    QuantumCircuit
        Parameters in a vector named ``"a"`` (``U_1``) or ``"b"`` (``U_2``).
    """
    prefix = "b" if second else "a"
    if family == "xx":
        return equivariant_commuting(num_qubits, "Y" if second else "X", max_weight,
                                     parameter_prefix=prefix)
    if family == "noncommuting":
        return equivariant_noncommuting(num_qubits, layers, parameter_prefix=prefix)
    if family == "qcnn":
        return qcnn(num_qubits, parameter_prefix=prefix)
    raise ValueError(f"family must be one of {FAMILIES}, got {family!r}")


def observable(family: str, num_qubits: int) -> SparsePauliOp:
    """``sum_i Z_i`` for the equivariant families, ``Z`` on the readout qubit for the QCNN."""
    if family == "qcnn":
        return SparsePauliOp.from_sparse_list([("Z", [qcnn_readout_qubit(num_qubits)], 1.0)],
                                              num_qubits)
    return equivariant_observable(num_qubits)


def single_model(family: str, num_qubits: int, second: bool, seed, *, max_weight: int = 3,
                 layers: int = 4) -> DensityQNN:
    """One sub-unitary on the angle encoding ``R_y(pi x_i / 2)`` (K = 1), angles uniform in
    ``[-pi, pi)`` from ``seed``."""
    circ = sub_unitary(family, num_qubits, second, max_weight=max_weight, layers=layers)
    return DensityQNN([circ], encoding=Encoding.angle(num_qubits),
                      observable=observable(family, num_qubits), seed=seed)


def train_recorded(model: DensityQNN, data: tuple, steps: int, *, batch_size: int,
                   learning_rate: float, eval_every: int, seed: int, post="linear",
                   snapshot_at: int | None = None, progress: bool = False,
                   readout: str = "head") -> dict:
    """Train ``model`` for ``steps`` Adam steps on mini-batches, scoring the test set every
    ``eval_every`` steps (and at step 0).

    A step is one Adam update on a mini-batch of ``batch_size`` rows: the unit Bowles et al.'s
    code (which the paper adapts) calls an iteration and the paper's Fig. 5 calls an epoch.

    Parameters
    ----------
    model : DensityQNN
        Template (deep-copied; its angles and mixture are the starting point).
    data : tuple
        ``(X_train, y_train, X_test, y_test)``.
    steps, batch_size, eval_every : int
    learning_rate : float
    seed : int
        Batch order (and the read-out head when ``post="linear"``).
    post : "linear" or layer
        Read-out head ``1 -> 2`` logits; a trained head is deep-copied (warm start).
    snapshot_at : int, optional
        Also return deep copies of the model and head after this many steps.
    readout : {"head", "sum_z"}
        ``"head"``: a read-out head on the model's output, cross entropy (QNNClassifier);
        ``"sum_z"``: the paper's ``f = sum_i <Z_i>`` itself, square loss against the +-1
        labels and the sign as the prediction (Bowles et al.'s code); ``post`` is unused and
        the snapshot's head is None.

    Returns
    -------
    dict
        ``steps`` and ``accuracy`` (lists, one entry per evaluation), ``estimator`` (the fitted
        QNNClassifier), and ``snapshot`` ``(model, head)`` when asked.
    """
    if readout not in ("head", "sum_z"):
        raise ValueError(f"readout must be 'head' or 'sum_z', got {readout!r}")
    X, y, Xt, yt = data
    record: dict = {"steps": [], "accuracy": [], "snapshot": None}
    plain = readout == "sum_z"

    def score(est) -> float:
        if not plain:
            return float(est.score(Xt, yt))
        return float(np.mean(np.where(est.predict(Xt) >= 0, 1, -1) == np.asarray(yt)))

    def callback(est, step):
        if step % eval_every == 0 or step == steps:
            record["steps"].append(step)
            record["accuracy"].append(score(est))
        if snapshot_at is not None and step == snapshot_at:
            record["snapshot"] = (copy.deepcopy(est.model_),
                                  None if plain else copy.deepcopy(est.post_))

    epochs = -(-steps * batch_size // X.shape[0])
    kind = QNNRegressor if plain else QNNClassifier
    est = kind(model, post=None if plain else post, optimizer="adam",
               learning_rate=learning_rate, epochs=max(epochs, 1), batch_size=batch_size,
               max_steps=steps, seed=int(seed), verbose=bool(progress), callback=callback)
    est.fit(X, np.asarray(y, dtype=float) if plain else y)
    record["estimator"] = est
    record["alpha"] = np.asarray(est.model_.alpha()[0], dtype=float)
    return record
