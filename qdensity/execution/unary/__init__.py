"""Unary engine: RBS / FBS circuits as n x n orthogonal matrices (paper Methods, Supp. D-F).

A circuit made only of :class:`~qdensity.circuits.gates.RBSGate` and
:class:`~qdensity.circuits.gates.FBSGate`
preserves Hamming weight. On the Hamming-weight-1 ("unary") subspace, spanned by the basis
states ``e_j`` (statevector entry ``2**j``, qubit ``j`` carries component ``j``), it acts as an
``n x n`` real orthogonal matrix ``O(theta)`` (paper Methods, "Hamming weight preserving QNNs";
Supp. D eq. 8): every gate is a Givens rotation of two coordinates,

    RBS(theta) on [i, j]:   y_i -> cos(theta) y_i - sin(theta) y_j,
                            y_j -> sin(theta) y_i + cos(theta) y_j,

and an FBS gate on ``[i, ..., j]`` acts on unary inputs as RBS on its first and last qubit
(the inner qubits are ``|0>``, so the parity sign of Supp. E eq. 24 is ``+1``). Simulating a
batch of ``B`` unary inputs therefore costs ``O(gates * B)`` flops instead of
``O(gates * 2^n * B)`` for a statevector.

Gradients are reverse-mode (backpropagation) through the rotations. Each rotation is
orthogonal, so the backward pass recovers the activations by undoing the rotations and
stores nothing: ``O(gates)`` time and ``O(n)`` memory per input (the paper's backpropagation
scaling, Definition "Backpropagation scaling", holds classically for this engine).

Angles may be ``a * p + b`` in one circuit parameter ``p`` (parameters may be shared by
several gates) or fixed numbers. Parameter values are given in ``circuit.parameters`` order.

Functions accept either a ``QuantumCircuit`` or a :class:`UnaryCircuit` from
:func:`compile_unary`; compile once when calling repeatedly.

Torch tensors (the optional ``torch`` extra): when an array argument of :func:`forward`,
:func:`vjp` or :func:`jacobian` is a ``torch.Tensor``, the same layers run on its device (CPU
or CUDA) and dtype (float32 or float64) and the results are tensors there (:mod:`._torch`).

Execution: with numba (a core dependency) one compiled call runs the whole circuit on a block
of batch rows -- the forward pass, or the forward and reverse pass of :func:`vjp` -- with no
Python between gates or layers (:mod:`._kernels`); without it (``QDENSITY_NUMBA=0``) the
layers run as numpy / scipy sparse products (:mod:`._plan`), same numbers to rounding.

Threads: a wide enough batch (about ``2**23`` multiply-adds per thread) is cut into contiguous
row blocks run in threads, with outputs and input gradients bit-for-bit those of one thread
(a summed parameter gradient adds the blocks' partial sums). The number is the usable cores
(at most 8), or the environment variable ``QDENSITY_NUM_THREADS`` (an integer >= 1; ``1``
disables the threads; anything else raises ``ValueError``). The kernels are plain loops, not
numpy's BLAS (but for the product of a composed ``O``), so BLAS thread settings do not multiply
with these threads.
"""

from __future__ import annotations

import math

import numpy as np
from qiskit.circuit import ParameterExpression, QuantumCircuit

from qdensity.analysis.gate_registry import GIVENS_GATES
from qdensity.analysis.structure import parameter_of
from qdensity.execution.unary import _kernels
from qdensity.execution.unary import _torch as _on_torch
from qdensity.execution.unary._circuit import UnaryCircuit
from qdensity.execution.unary._compiled import forward_rows, vjp_rows
from qdensity.execution.unary._inputs import batch as _batch
from qdensity.execution.unary._inputs import inputs as _inputs
from qdensity.execution.unary._inputs import rows_values as _rows_values
from qdensity.execution.unary._inputs import values as _values
from qdensity.execution.unary._plan import reverse
from qdensity.execution.unary._plan import rotate_columns as _rotate
from qdensity.validation import (
    MAX_CIRCUIT_QUBITS,
    MAX_DENSE_ENTRIES,
    Array,
    Circuit,
    Instance,
    Options,
    TorchTensor,
    validates,
)

__all__ = [
    "UnaryCircuit",
    "MAX_UNARY_GATES",
    "compile_unary",
    "orthogonal_matrix",
    "forward",
    "vjp",
    "jacobian",
]

_IGNORED = frozenset({"barrier"})

#: Most instructions :func:`compile_unary` reads (2**21: a pyramid on about 2,000 qubits; each
#: gate costs about 30 us to compile, so this is about a minute).
MAX_UNARY_GATES = 2**21


@validates(circuit=[Circuit(min_qubits=1), Instance(UnaryCircuit)])
def compile_unary(circuit: QuantumCircuit) -> UnaryCircuit:
    """Extract the Givens rotations of an RBS / FBS circuit once.

    Parameters
    ----------
    circuit : QuantumCircuit
        Only ``rbs`` and ``fbs`` gates (barriers are ignored). Each angle is a number or
        ``a * p + b`` in a single parameter ``p``; the global phase must be zero.

    Returns
    -------
    UnaryCircuit

    Raises
    ------
    ValueError
        Naming the first unsupported instruction (anything but ``rbs``, ``fbs``, ``barrier``),
        an angle that is not linear in one parameter, or a non-zero global phase.

    Examples
    --------
    >>> from qdensity.circuits.ansatze import pyramid
    >>> compiled = compile_unary(pyramid(4))
    >>> compiled.num_gates, compiled.num_parameters
    (6, 6)
    """
    if isinstance(circuit, UnaryCircuit):
        return circuit
    if len(circuit.data) > MAX_UNARY_GATES:  # compiling reads each gate (~30 us): minutes
        raise ValueError(
            f"circuit has {len(circuit.data)} instructions, more than the {MAX_UNARY_GATES} the "
            f"unary engine compiles (about a minute at that size; a pyramid on "
            f"{circuit.num_qubits} qubits has n(n-1)/2 gates): use an ansatz of fewer gates "
            f"(butterfly: n log n), fewer qubits, or sample() with shots")
    phase = circuit.global_phase
    if isinstance(phase, ParameterExpression) and phase.parameters:
        raise ValueError(
            f"circuit has a parameterised global phase {phase}; the unary engine computes real "
            "amplitudes and needs global phase 0"
        )
    if abs(math.remainder(float(phase), 2 * math.pi)) > 1e-12:
        raise ValueError(
            f"circuit has global phase {float(phase)!r}; the unary engine computes real "
            "amplitudes and needs global phase 0"
        )
    params = tuple(circuit.parameters)
    position = {p: k for k, p in enumerate(params)}
    first, second, pidx, coeff, offset = [], [], [], [], []
    for index, inst in enumerate(circuit.data):
        name = inst.operation.name
        if name in _IGNORED:
            continue
        if name not in GIVENS_GATES:
            raise ValueError(
                f"circuit instruction {index} is {name!r} on qubits "
                f"{[circuit.find_bit(q).index for q in inst.qubits]}; the unary engine supports "
                f"only {' and '.join(map(repr, GIVENS_GATES))} gates (and barriers)"
            )
        qubits = [circuit.find_bit(q).index for q in inst.qubits]
        first.append(qubits[0])
        second.append(qubits[-1])
        angle = inst.operation.params[0]
        found = parameter_of(inst)
        if found is None:
            pidx.append(-1)
            coeff.append(0.0)
            offset.append(float(angle))
        else:
            param, a = found
            pidx.append(position[param])
            coeff.append(float(a))
            offset.append(float(angle.bind({param: 0.0})))
    return UnaryCircuit(
        num_qubits=circuit.num_qubits,
        parameters=params,
        first=np.asarray(first, dtype=np.intp),
        second=np.asarray(second, dtype=np.intp),
        parameter_index=np.asarray(pidx, dtype=np.intp),
        coefficient=np.asarray(coeff, dtype=float),
        offset=np.asarray(offset, dtype=float),
    )


@validates(circuit=[Circuit(), Instance(UnaryCircuit)], values=[Array(ndim=1, min_size=0), None])
def orthogonal_matrix(circuit: QuantumCircuit | UnaryCircuit, values=None) -> np.ndarray:
    """The orthogonal matrix ``O`` of a circuit on unary states: ``y = O @ x``.

    ``O[k, j]`` is the amplitude of ``e_k`` (statevector entry ``2**k``) when the circuit acts
    on ``e_j`` (paper Methods, Supp. D).

    Parameters
    ----------
    circuit : QuantumCircuit or UnaryCircuit
        RBS / FBS circuit on ``n`` qubits.
    values : array_like, shape (P,)
        Parameter values in ``circuit.parameters`` order (may be omitted when ``P == 0``).

    Returns
    -------
    numpy.ndarray, shape (n, n)
        Real orthogonal with determinant ``+1``.

    Raises
    ------
    ValueError
        Unsupported gate, or ``values`` of the wrong shape.

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.circuits.ansatze import pyramid
    >>> O = orthogonal_matrix(pyramid(3), [0.1, 0.2, 0.3])
    >>> bool(np.allclose(O @ O.T, np.eye(3)))
    True
    """
    compiled = compile_unary(circuit)
    v = _values(compiled, values)
    return _rotate(np.eye(compiled.num_qubits), compiled, compiled.angles(v))


@validates(
    circuit=[Circuit(), Instance(UnaryCircuit)],
    X=[TorchTensor((1, 2)), Array(ndim=(1, 2), max_size=MAX_DENSE_ENTRIES)],
    values=[TorchTensor((1, 2)), Array(ndim=(1, 2), min_size=0, max_size=MAX_DENSE_ENTRIES),
            None],
)
def forward(circuit: QuantumCircuit | UnaryCircuit, X, values=None) -> np.ndarray:
    """Output unary amplitudes ``y_b = O(values_b) @ x_b`` for a batch of inputs.

    Parameters
    ----------
    circuit : QuantumCircuit or UnaryCircuit
        RBS / FBS circuit on ``n`` qubits.
    X : array_like, shape (n,) or (B, n)
        Input unary amplitudes (not required to be normalised; the map is linear).
    values : array_like, shape (P,) or (B, P)
        Parameter values, shared by the batch or one row per input. With ``X`` of shape
        ``(n,)`` and ``values`` of shape ``(B, P)`` the one input is run under every row.

    Returns
    -------
    numpy.ndarray, shape (n,) or (B, n)
        1-d only when both ``X`` and ``values`` are 1-d.

    Notes
    -----
    The Givens rotations are applied gate by gate to the batch, ``6 G B`` flops. With shared
    values, ``O`` is built first (``6 G n``) and applied as one matrix product (``2 n^2 B``)
    when that costs fewer (weighted) flops: a deep circuit on a batch much wider than ``n``.

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.circuits.ansatze import pyramid
    >>> y = forward(pyramid(4), np.eye(4)[0], np.zeros(6))
    >>> y.tolist()
    [1.0, 0.0, 0.0, 0.0]
    """
    compiled = circuit if isinstance(circuit, UnaryCircuit) else compile_unary(circuit)
    if _on_torch.any_tensor(X, values):
        return _on_torch.forward(compiled, X, values)
    if _kernels.available():  # one compiled call per block of rows: the whole circuit
        Xr, v, single = _rows_values(compiled, X, values, declared=True)
        Y = forward_rows(Xr, compiled, v)
        return Y[0].copy() if single else Y
    Z, angles, single = _batch(compiled, X, values)
    if angles.ndim == 1 and Z.shape[1] > compiled.num_qubits:
        Z = _rotate(np.eye(compiled.num_qubits), compiled, angles) @ Z
    else:
        Z = _rotate(Z, compiled, angles)
    return Z[:, 0].copy() if single else np.ascontiguousarray(Z.T)


@validates(
    circuit=[Circuit(), Instance(UnaryCircuit)],
    X=[TorchTensor((1, 2)), Array(ndim=(1, 2), max_size=MAX_DENSE_ENTRIES)],
    values=[TorchTensor((1, 2)), Array(ndim=(1, 2), min_size=0, max_size=MAX_DENSE_ENTRIES),
            None],
    grad_Y=[TorchTensor((1, 2)), Array(ndim=(1, 2), max_size=MAX_DENSE_ENTRIES)],
    reduce=Options(('none', 'sum')), outputs=[TorchTensor((1, 2)), Array(ndim=(1, 2)), None],
)
def vjp(
    circuit: QuantumCircuit | UnaryCircuit,
    X,
    values,
    grad_Y,
    *,
    reduce: str = "none",
    outputs=None,
) -> tuple[np.ndarray, np.ndarray]:
    """Vector-Jacobian product (backpropagation) of :func:`forward`.

    For a scalar loss ``L(Y)`` with ``grad_Y = dL/dY`` this returns ``dL/dvalues`` and
    ``dL/dX``. The backward pass walks the gates in reverse; for a gate rotating ``(i, j)`` by
    ``theta = a * p + b`` with outputs ``(u_i, u_j)`` and incoming gradient ``(g_i, g_j)``:

        dL/dtheta = g_i du_i/dtheta + g_j du_j/dtheta = -g_i u_j + g_j u_i,
        dL/dp    += a * dL/dtheta,

    then the gradient and the activations are rotated back by ``-theta`` (``O`` is
    orthogonal, so the activations before the gate are recovered exactly and none is stored).
    Cost ``O(G)`` per input, about twice a forward pass.

    Parameters
    ----------
    circuit : QuantumCircuit or UnaryCircuit
    X : array_like, shape (n,) or (B, n)
    values : array_like, shape (P,) or (B, P)
        As in :func:`forward`.
    grad_Y : array_like, same shape as ``forward(circuit, X, values)``
    reduce : {"none", "sum"}
        ``"none"``: per-example gradients ``grad_values`` of shape ``(B, P)`` (or ``(P,)``
        for a single input). ``"sum"``: summed over the batch, shape ``(P,)`` -- the gradient
        of a loss that adds the per-example losses, and the right one for shared values;
        it never allocates the per-example ``(B, P)`` array.
    outputs : array_like, optional
        ``forward(circuit, X, values)`` if the caller has it: the backward pass starts there
        instead of running the forward pass again (only its shape is checked).

    Returns
    -------
    grad_values : numpy.ndarray, shape (B, P) or (P,)
    grad_X : numpy.ndarray, same shape as the output (``O(values_b)^T @ grad_Y_b``)

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.circuits.ansatze import pyramid
    >>> gv, gx = vjp(pyramid(2), [1.0, 0.0], [0.0], [0.0, 1.0])
    >>> gv.round(12).tolist(), gx.round(12).tolist()
    ([1.0], [0.0, 1.0])
    """
    compiled = circuit if isinstance(circuit, UnaryCircuit) else compile_unary(circuit)
    if _on_torch.any_tensor(X, values, grad_Y, outputs):
        return _on_torch.vjp(compiled, X, values, grad_Y, reduce, outputs)
    Xr, v, single = _rows_values(compiled, X, values, declared=True)
    B, n = Xr.shape
    gy = np.asarray(grad_Y, dtype=float)  # declared real and finite
    expected = (n,) if single else (B, n)
    if gy.shape != expected:
        raise ValueError(f"grad_Y must have the output's shape {expected}, got {gy.shape}")
    if outputs is not None and np.shape(outputs) != expected:
        raise ValueError(f"outputs must have the output's shape {expected}, got "
                         f"{np.shape(outputs)}")
    per_example = reduce == "none" and not single
    if _kernels.available():  # forward and reverse pass in one compiled call per row block
        src = Xr if outputs is None else np.ascontiguousarray(np.atleast_2d(outputs),
                                                               dtype=float)
        grad_p, gX = vjp_rows(src, np.ascontiguousarray(np.atleast_2d(gy), dtype=float),
                              outputs is not None, compiled, v, per_example)
        if single:
            return grad_p, gX[0].copy()
        return (np.ascontiguousarray(grad_p.T) if per_example else grad_p), gX
    Z, angles = np.array(Xr.T, order="C"), compiled.angles(v)
    G = np.array(np.atleast_2d(gy).T, dtype=float, order="C")
    # forward to the outputs (or start from the caller's)
    if outputs is not None:
        Y = np.array(np.atleast_2d(outputs).T, dtype=float, order="C")
    elif angles.ndim == 1 and B > n:
        Y = _rotate(np.eye(n), compiled, angles) @ Z
    else:
        Y = _rotate(Z, compiled, angles)
    grad_p = reverse(Y, G, compiled, angles, per_example)
    grad_X = G.T
    if single:
        return grad_p, grad_X[0].copy()
    grad_values = grad_p.T if per_example else grad_p
    return np.ascontiguousarray(grad_values), np.ascontiguousarray(grad_X)


@validates(
    circuit=[Circuit(), Instance(UnaryCircuit)],
    x=[TorchTensor(1), Array(ndim=1, max_size=MAX_CIRCUIT_QUBITS)],
    values=[TorchTensor(1), Array(ndim=1, min_size=0), None],
)
def jacobian(circuit: QuantumCircuit | UnaryCircuit, x, values=None) -> np.ndarray:
    """Jacobian ``dy_k / dvalues_p`` of one output (reverse mode, one pass per output).

    Parameters
    ----------
    circuit : QuantumCircuit or UnaryCircuit
    x : array_like, shape (n,)
        One input.
    values : array_like, shape (P,)

    Returns
    -------
    numpy.ndarray, shape (n, P)
        ``J[k, p] = d y_k / d values[p]``. (The Jacobian in ``x`` is ``orthogonal_matrix``.)

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.circuits.ansatze import pyramid
    >>> jacobian(pyramid(2), [1.0, 0.0], [0.0]).round(12).tolist()
    [[0.0], [1.0]]
    """
    compiled = compile_unary(circuit)
    if _on_torch.any_tensor(x, values):
        return _on_torch.jacobian(compiled, x, values)
    x = _inputs(compiled, x, "x")
    v = _values(compiled, values)
    n = compiled.num_qubits
    grad_values, _ = vjp(compiled, np.broadcast_to(x, (n, n)), v, np.eye(n))
    return grad_values
