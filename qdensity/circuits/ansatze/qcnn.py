"""Quantum convolutional neural network (Cong et al.), as used by Bowles et al. (paper Fig. 4c).

The register starts with all ``n`` qubits *active*. Each layer, on the ``m`` active qubits
``a_0 < a_1 < ... < a_{m-1}``:

* **convolution** -- the same 10-parameter two-qubit block :math:`C(φ)` on the ring edges
  ``(a_i, a_{i+1 mod m})``, first the even ``i`` then the odd ``i`` (brick wall, closed
  into a ring); for ``m = 2`` there is the single edge ``(a_0, a_1)``;
* **pooling** -- the same 2-parameter block :math:`P(ψ)` from the discarded qubit ``a_{2j}``
  onto the kept qubit ``a_{2j+1}`` for ``j < floor(m / 2)``; with odd ``m`` the last active
  qubit passes through. Discarded qubits are never touched again (no mid-circuit measurement:
  pooling is coherent control).

The active count goes ``m -> ceil(m / 2)``, so there are ``ceil(log2 n)`` layers and the last
active qubit, the readout, is always ``n - 1``. For ``n = 16`` this reproduces the 29
convolution and 15 pooling blocks of Bowles et al.

Blocks (Bowles et al.'s code, gate order left to right)::

    C(φ) on (u, v): rx(φ0) u, rx(φ1) v, rz(φ2) u, rz(φ3) v, crz(φ4) v->u, crz(φ5) u->v,
                    rx(φ6) u, rx(φ7) v, rz(φ8) u, rz(φ9) v
    P(ψ) from c onto t: crz(ψ0) c->t, x c, crx(ψ1) c->t, x c

Parameter count: ``12 ceil(log2 n)`` (10 convolution + 2 pooling, shared within a layer).
"""

from __future__ import annotations

from qiskit.circuit import ParameterVector, QuantumCircuit

from qdensity.validation import Instance, Qubits, check_num_qubits, validates

__all__ = [
    "qcnn",
    "qcnn_readout_qubit",
    "qcnn_layers",
    "CONV_PARAMETERS",
    "POOL_PARAMETERS",
]

#: Parameters of one convolution block.
CONV_PARAMETERS = 10
#: Parameters of one pooling block.
POOL_PARAMETERS = 2


def _check_n(num_qubits: int) -> int:
    return check_num_qubits(num_qubits, minimum=2)


@validates(num_qubits=Qubits(2))
def qcnn_layers(num_qubits: int) -> list[tuple[list[tuple[int, int]], list[tuple[int, int]]]]:
    """Qubit pairs of every QCNN layer: ``(convolution edges, pooling (discarded, kept))``.

    Parameters
    ----------
    num_qubits : int
        ``n >= 2``.

    Returns
    -------
    list of (list of (int, int), list of (int, int))
        ``ceil(log2 n)`` entries in circuit order.

    Examples
    --------
    >>> qcnn_layers(5)[1]
    ([(1, 3), (4, 1), (3, 4)], [(1, 3)])
    """
    n = _check_n(num_qubits)
    active = list(range(n))
    out = []
    while len(active) > 1:
        m = len(active)
        edges = [(active[i], active[(i + 1) % m]) for i in range(m if m > 2 else 1)]
        conv = edges[0::2] + edges[1::2]
        pool = [(active[2 * j], active[2 * j + 1]) for j in range(m // 2)]
        out.append((conv, pool))
        active = [active[2 * j + 1] for j in range(m // 2)] + ([active[-1]] if m % 2 else [])
    return out


@validates(num_qubits=Qubits(2))
def qcnn_readout_qubit(num_qubits: int) -> int:
    """The qubit left active after the last pooling layer (measure ``Z`` there).

    Parameters
    ----------
    num_qubits : int
        ``n >= 2``.

    Returns
    -------
    int
        ``n - 1``.

    Examples
    --------
    >>> qcnn_readout_qubit(8)
    7
    """
    layers = qcnn_layers(num_qubits)
    return layers[-1][1][-1][1]


def _conv_block(qc: QuantumCircuit, phi, u: int, v: int) -> None:
    qc.rx(phi[0], u)
    qc.rx(phi[1], v)
    qc.rz(phi[2], u)
    qc.rz(phi[3], v)
    qc.crz(phi[4], v, u)
    qc.crz(phi[5], u, v)
    qc.rx(phi[6], u)
    qc.rx(phi[7], v)
    qc.rz(phi[8], u)
    qc.rz(phi[9], v)


def _pool_block(qc: QuantumCircuit, psi, control: int, target: int) -> None:
    qc.crz(psi[0], control, target)
    qc.x(control)
    qc.crx(psi[1], control, target)
    qc.x(control)


@validates(
    num_qubits=Qubits(2), parameter_prefix=Instance(str), insert_barriers=Instance(bool),
    name=[Instance(str), None],
)
def qcnn(
    num_qubits: int,
    *,
    parameter_prefix: str = "θ",
    insert_barriers: bool = False,
    name: str | None = None,
) -> QuantumCircuit:
    """QCNN of convolution and pooling layers down to one readout qubit (Cong et al.).

    See the module docstring for the blocks and the qubit pattern (:func:`qcnn_layers`).
    Layer ``l`` uses ``θ[12 l .. 12 l + 9]`` for every convolution block and
    ``θ[12 l + 10], θ[12 l + 11]`` for every pooling block.

    Parameters
    ----------
    num_qubits : int
        ``n >= 2`` (any ``n``; an odd active qubit out passes through a pooling layer).
    parameter_prefix : str
        Name of the trainable ``ParameterVector`` (length ``12 ceil(log2 n)``).
    insert_barriers : bool
        Barrier between the convolution and pooling parts of each layer (for drawing).
    name : str, optional
        Circuit name; defaults to ``"qcnn_{n}"``.

    Returns
    -------
    QuantumCircuit
        ``n`` qubits, ``12 ceil(log2 n)`` parameters; the model output is ``<Z_r>`` with
        ``r = qcnn_readout_qubit(n) = n - 1``.

    Raises
    ------
    ValueError
        For ``num_qubits < 2``.

    Examples
    --------
    >>> qc = qcnn(8)
    >>> qc.num_parameters, qc.count_ops()["crx"], qcnn_readout_qubit(8)
    (36, 7, 7)
    """
    n = _check_n(num_qubits)
    layers = qcnn_layers(n)
    per_layer = CONV_PARAMETERS + POOL_PARAMETERS
    theta = ParameterVector(parameter_prefix, per_layer * len(layers))
    qc = QuantumCircuit(n, name=name or f"qcnn_{n}")
    for layer, (conv, pool) in enumerate(layers):
        base = layer * per_layer
        phi = theta[base : base + CONV_PARAMETERS]
        psi = theta[base + CONV_PARAMETERS : base + per_layer]
        for u, v in conv:
            _conv_block(qc, phi, u, v)
        if insert_barriers:
            qc.barrier()
        for control, target in pool:
            _pool_block(qc, psi, control, target)
        if insert_barriers and layer < len(layers) - 1:
            qc.barrier()
    return qc
