"""Warm start of a density QNN from separately trained sub-unitaries (paper, Methods).

The paper's protocol: train the K sub-unitaries in parallel (each as a model of its own), then
initialise the density model ``f = sum_k alpha_k f_k`` with their trained angles and an alpha
given up front (e.g. 0.99 on the best sub-unitary and 0.01 on the other), and go on training
the density model.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from qdensity.models.decompositions import independent, trainable_parameters
from qdensity.models.density import DensityQNN
from qdensity.models.registry import MIXTURES as MIXTURE_KINDS
from qdensity.validation import (
    MAX_SUBUNITARIES,
    Array,
    Instance,
    Options,
    SequenceOf,
    check_distribution,
    validates,
)

__all__ = ["warm_start", "MIXTURES"]

#: Mixtures a warm-started model may start with: those of the mixture registry that can start
#: from a given alpha.
MIXTURES = tuple(name for name, kind in MIXTURE_KINDS.items() if kind.from_alpha is not None)


@validates(
    sub_models=SequenceOf(Instance(DensityQNN), max_len=MAX_SUBUNITARIES),
    alpha=Array(ndim=1, max_size=MAX_SUBUNITARIES), mixture=Options(MIXTURES),
)
def warm_start(sub_models: Sequence[DensityQNN], alpha, *, mixture: str = "softmax"
               ) -> DensityQNN:
    """A density QNN whose sub-unitaries start at the angles of K trained models.

    Parameters
    ----------
    sub_models : sequence of DensityQNN
        K >= 1 trained models of one sub-unitary each, all with the same width, encoding,
        readout and observable (those of ``sub_models[0]`` are used).
    alpha : array_like, shape (K,)
        Initial mixture weights on the simplex (e.g. ``[0.99, 0.01]``); with
        ``mixture="softmax"`` every weight must be positive (the logits are ``log alpha``).
    mixture : {"softmax", "fixed"}
        A trainable softmax over the K sub-unitaries, or alpha kept fixed.

    Returns
    -------
    DensityQNN
        ``K`` sub-unitaries; ``f(x) = sum_k alpha_k f_k(x)`` (eq. 3) with ``f_k`` exactly the
        trained ``sub_models[k]``'s output. Sub-unitaries that share parameter objects are
        given independent copies (Cor. 1), so each keeps its own trained angles.

    Raises
    ------
    ValueError
        For an empty list, a sub-model with K != 1, mismatched widths or readouts, alpha off
        the simplex or of the wrong length, or an unknown ``mixture``.

    Examples
    --------
    >>> from qiskit.quantum_info import SparsePauliOp
    >>> from qdensity.circuits.ansatze import reuploading
    >>> a = DensityQNN([reuploading(2, parameter_prefix="a")], seed=0)
    >>> b = DensityQNN([reuploading(2, parameter_prefix="b")], seed=1)
    >>> model = warm_start([a, b], [0.99, 0.01])
    >>> x = [[0.3]]
    >>> bool(np.allclose(model.predict(x), 0.99 * a.predict(x) + 0.01 * b.predict(x)))
    True
    """
    subs = list(sub_models)
    for i, m in enumerate(subs):
        if m.num_subunitaries != 1:
            raise ValueError(f"sub_models[{i}] has K = {m.num_subunitaries} sub-unitaries; each "
                             "trained model must hold one")
    first = subs[0]
    for i, m in enumerate(subs[1:], start=1):
        if m.num_qubits != first.num_qubits or m.readout != first.readout:
            raise ValueError(f"sub_models[{i}] has width {m.num_qubits} and readout "
                             f"{m.readout!r}; sub_models[0] has {first.num_qubits} and "
                             f"{first.readout!r}")
        if m.readout == "observable" and not m.observable.equiv(first.observable):
            raise ValueError(f"sub_models[{i}] reads a different observable than sub_models[0]")
    alpha = check_distribution(alpha, "alpha")
    if alpha.shape != (len(subs),):
        raise ValueError(f"alpha must have one weight per sub-model ({len(subs)}), got "
                         f"{alpha.shape}")
    if mixture == "softmax" and np.any(alpha <= 0):
        raise ValueError("alpha must be positive for mixture='softmax' (logits are log alpha); "
                         "use mixture='fixed' for zero weights")
    circuits = [m.sub_unitaries[0] for m in subs]
    seen: set = set()
    shared = False
    for c in circuits:
        params = set(trainable_parameters(c))
        shared |= bool(seen & params)
        seen |= params
    if shared:
        circuits = independent(circuits).sub_unitaries
    from_alpha = MIXTURE_KINDS[mixture].from_alpha
    if from_alpha is None:  # declared away: MIXTURES lists only mixtures with one
        raise ValueError(f"mixture must be one of {MIXTURES}, got {mixture!r}")
    mix = from_alpha(alpha)
    model = DensityQNN(circuits, mix, encoding=first.encoding, observable=first.observable,
                       readout=first.readout)
    theta = np.zeros(model.num_parameters)
    for k, m in enumerate(subs):
        theta[model.subunitary_parameter_indices(k)] = m.theta
    model.set_params(theta)
    return model
