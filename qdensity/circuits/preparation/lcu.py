"""The LCU QNN of Fig. 1a: Fig. 1b then ``Load(sqrt(alpha))^dagger``, post-select ``mix = 0``.

Besides the circuit, the exact success probability ``||sum_k alpha_k U_k |x>||^2`` and the
post-selected data state (exact statevector simulation), for checks and small models.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from qiskit.circuit import QuantumCircuit, QuantumRegister
from qiskit.quantum_info import Operator, Statevector

from qdensity.circuits.loaders import distribution_loader, unary_loader_template
from qdensity.circuits.preparation._common import (
    DATA_REGISTER,
    MIX_REGISTER,
    _append_circuit,
    _check_alpha,
    _check_loader,
    _check_parameter_names,
    _check_sub_unitaries,
)
from qdensity.circuits.preparation._controlled import _append_controlled_circuit
from qdensity.circuits.preparation.deterministic import deterministic_circuit
from qdensity.validation import (
    MAX_SUBUNITARIES,
    Array,
    Circuit,
    Instance,
    SequenceOf,
    validates,
)

__all__ = ["lcu_circuit", "lcu_template", "lcu_success_probability", "lcu_postselected_state"]


@validates(
    sub_unitaries=SequenceOf(Circuit(min_qubits=1), max_len=MAX_SUBUNITARIES), alpha=Array(ndim=1),
    loader=[Circuit(min_qubits=1), None],
)
def lcu_circuit(
    sub_unitaries: Sequence[QuantumCircuit],
    alpha,
    loader: QuantumCircuit | None = None,
) -> QuantumCircuit:
    """The LCU QNN of Fig. 1a: Fig. 1b followed by ``Load(sqrt(alpha))^dagger`` on ``mix``.

    Projecting ``mix`` onto ``|0...0>`` applies ``<0| Load^dagger = sum_k sqrt(alpha_k) <e_k|``
    to ``sum_k sqrt(alpha_k) |e_k> U_k |x>``, leaving ``A |x> = sum_k alpha_k U_k |x>`` on
    ``data``. Success (``mix`` measures all zeros) has probability ``||A |x>||^2``
    (:func:`lcu_success_probability`); the post-selected state is ``A|x> / ||A|x>||``.

    Parameters
    ----------
    sub_unitaries, alpha, loader
        As in :func:`deterministic_circuit`.

    Returns
    -------
    QuantumCircuit
        ``K + n`` qubits, registers ``"mix"`` then ``"data"``; ``metadata["postselect"]``
        is ``{"mix": 0}``.

    Examples
    --------
    >>> from qdensity.circuits.ansatze import pyramid
    >>> qc = lcu_circuit([pyramid(3, parameter_prefix="a"), pyramid(3, parameter_prefix="b")],
    ...                  [0.5, 0.5])
    >>> qc.num_qubits
    5
    """
    circuits = _check_sub_unitaries(sub_unitaries)
    arr = _check_alpha(alpha, len(circuits))
    qc = deterministic_circuit(circuits, arr, loader)
    mix = qc.qregs[0]
    _append_circuit(qc, distribution_loader(arr).inverse(), list(mix))
    qc.name = "density_lcu"
    qc.metadata = {"alpha": arr.tolist(), "mix_register": MIX_REGISTER, "postselect": {"mix": 0}}
    return qc


@validates(
    sub_unitaries=SequenceOf(Circuit(min_qubits=1), max_len=MAX_SUBUNITARIES),
    loader=[Circuit(min_qubits=1), None], parameter_prefix=Instance(str),
)
def lcu_template(
    sub_unitaries: Sequence[QuantumCircuit],
    loader: QuantumCircuit | None = None,
    *,
    parameter_prefix: str = "ψ",
) -> QuantumCircuit:
    """:func:`lcu_circuit` with ``Load(sqrt(alpha))`` left as parameters: one template for
    every data point when ``alpha`` depends on the data (the MoE gate of Supp. C / H).

    ``Load(sqrt(alpha))`` is the parallel unary loader
    (:func:`~qdensity.circuits.loaders.unary_loader_template`) on ``mix`` with ``K - 1`` RBS
    angles in the vector ``parameter_prefix``; the closing ``Load(sqrt(alpha))^dagger`` uses the
    same parameters. Bound with ``loader_angles(sqrt(alpha))`` it is, gate for gate,
    :func:`lcu_circuit` ``(sub_unitaries, alpha, loader)``.

    Parameters
    ----------
    sub_unitaries : sequence of QuantumCircuit, length K >= 2
        ``U_1 .. U_K`` on ``n`` qubits, parameterised or bound.
    loader : QuantumCircuit, optional
        ``V(x)`` on the ``n`` data qubits (parameterised or bound). None: ``|0...0>``.
    parameter_prefix : str
        Name of the ``ParameterVector`` of the ``K - 1`` mixing angles.

    Returns
    -------
    QuantumCircuit
        ``K + n`` qubits, registers ``"mix"`` then ``"data"``; ``metadata`` holds
        ``"mix_register"``, ``"postselect": {"mix": 0}`` and ``"alpha_parameters"`` (the names
        of the mixing angles in binding order).

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.circuits.ansatze import pyramid
    >>> from qdensity.circuits.loaders import loader_angles
    >>> subs = [pyramid(3, parameter_prefix="a"), pyramid(3, parameter_prefix="b")]
    >>> tpl = lcu_template(subs)
    >>> tpl.num_qubits, len(tpl.metadata["alpha_parameters"])
    (5, 1)
    """
    circuits = _check_sub_unitaries(sub_unitaries)
    if len(circuits) < 2:
        raise ValueError("lcu_template needs K >= 2 sub-unitaries (with K = 1 there is no "
                         "mixing register to parameterise: use lcu_circuit)")
    loader = _check_loader(loader, circuits[0].num_qubits)
    mix_loader = unary_loader_template(len(circuits), parameter_prefix=parameter_prefix)
    named = [(f"sub_unitaries[{k}]", c) for k, c in enumerate(circuits)]
    named.append(("the mixing loader", mix_loader))
    if loader is not None:
        named.append(("loader", loader))
    _check_parameter_names(named)
    mix = QuantumRegister(len(circuits), MIX_REGISTER)
    data = QuantumRegister(circuits[0].num_qubits, DATA_REGISTER)
    qc = QuantumCircuit(mix, data, name="density_lcu")
    _append_circuit(qc, mix_loader, list(mix))
    if loader is not None:
        _append_circuit(qc, loader, list(data))
    for k, circ in enumerate(circuits):
        _append_controlled_circuit(qc, mix[k], list(data), circ)
    _append_circuit(qc, mix_loader.inverse(), list(mix))
    qc.metadata = {"mix_register": MIX_REGISTER, "postselect": {"mix": 0},
                   "alpha_parameters": [p.name for p in mix_loader.parameters]}
    return qc


def _bound(circuit: QuantumCircuit, name: str) -> QuantumCircuit:
    if circuit.parameters:
        names = ", ".join(p.name for p in list(circuit.parameters)[:5])
        raise ValueError(
            f"{name} has {circuit.num_parameters} unbound parameters ({names}, ...); bind them "
            "with assign_parameters before an exact simulation"
        )
    return circuit


def _data_statevector(data_state, width: int) -> Statevector:
    if data_state is None:
        return Statevector.from_label("0" * width)
    if isinstance(data_state, QuantumCircuit):
        _check_loader(data_state, width)
        return Statevector(_bound(data_state, "data_state"))
    if isinstance(data_state, Statevector):
        if data_state.num_qubits != width:
            raise ValueError(
                f"data_state must be a state of the {width} data qubits, got "
                f"{data_state.num_qubits} qubits"
            )
        return data_state
    raise TypeError(
        "data_state must be a Statevector, a loader QuantumCircuit or None, got "
        f"{type(data_state).__name__}"
    )


@validates(
    sub_unitaries=SequenceOf(Circuit(min_qubits=1), max_len=MAX_SUBUNITARIES), alpha=Array(ndim=1),
    data_state=[Instance(Statevector), Circuit(min_qubits=1), None],
)
def lcu_success_probability(
    sub_unitaries: Sequence[QuantumCircuit],
    alpha,
    data_state: Statevector | QuantumCircuit | None = None,
) -> float:
    """Exact post-selection probability of the LCU QNN: ``||sum_k alpha_k U_k |x>||^2``.

    Parameters
    ----------
    sub_unitaries : sequence of QuantumCircuit, length K
        Bound sub-unitaries on ``n`` qubits.
    alpha : array_like, shape (K,)
        Distribution over the sub-unitaries.
    data_state : Statevector, QuantumCircuit or None
        ``|x>``: a state of ``n`` qubits, a bound loader circuit ``V(x)``, or None for
        ``|0...0>``.

    Returns
    -------
    float
        In ``[0, 1]`` (by the triangle inequality, ``||A|x>|| <= sum_k alpha_k = 1``).

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> u0, u1 = QuantumCircuit(1), QuantumCircuit(1)
    >>> _ = u1.x(0)
    >>> round(lcu_success_probability([u0, u1], [0.5, 0.5]), 6)
    0.5
    """
    circuits = _check_sub_unitaries(sub_unitaries)
    arr = _check_alpha(alpha, len(circuits))
    x = _data_statevector(data_state, circuits[0].num_qubits).data
    out = np.zeros_like(x, dtype=complex)
    for k, (a, circ) in enumerate(zip(arr, circuits, strict=True)):
        out += a * (Operator(_bound(circ, f"sub_unitaries[{k}]")).data @ x)
    return float(np.vdot(out, out).real)


@validates(
    sub_unitaries=SequenceOf(Circuit(min_qubits=1), max_len=MAX_SUBUNITARIES), alpha=Array(ndim=1),
    loader=[Circuit(min_qubits=1), None],
)
def lcu_postselected_state(
    sub_unitaries: Sequence[QuantumCircuit],
    alpha,
    loader: QuantumCircuit | None = None,
) -> Statevector:
    """Post-selected data state of :func:`lcu_circuit`, from an exact statevector simulation.

    Simulates the LCU circuit, projects ``mix`` onto ``|0...0>`` and normalises:
    ``sum_k alpha_k U_k |x> / ||sum_k alpha_k U_k |x>||``.

    Parameters
    ----------
    sub_unitaries, alpha, loader
        As in :func:`lcu_circuit`, all bound.

    Returns
    -------
    Statevector
        On the ``n`` data qubits, unit norm.

    Raises
    ------
    ValueError
        If a circuit has unbound parameters, or the success probability is below ``1e-12``
        (the post-selected state is then undefined).

    Examples
    --------
    Two sub-unitaries at their zero angles act as the identity: the data state is ``|0...0>``:

    >>> from qdensity.circuits.ansatze import pyramid
    >>> subs = [pyramid(3, parameter_prefix=p) for p in "ab"]
    >>> subs = [s.assign_parameters([0.0] * s.num_parameters) for s in subs]
    >>> state = lcu_postselected_state(subs, [0.5, 0.5])
    >>> state.num_qubits, round(float(abs(state.data[0])), 6)
    (3, 1.0)
    """
    circuits = _check_sub_unitaries(sub_unitaries)
    arr = _check_alpha(alpha, len(circuits))
    for k, circ in enumerate(circuits):
        _bound(circ, f"sub_unitaries[{k}]")
    if loader is not None:
        _bound(loader, "loader")
    qc = lcu_circuit(circuits, arr, loader)
    num_mix = len(circuits)
    amplitudes = Statevector(qc).data[:: 2**num_mix]  # entries with mix = 0...0
    probability = float(np.vdot(amplitudes, amplitudes).real)
    if probability < 1e-12:
        raise ValueError(
            f"the LCU success probability is {probability:.3g} (sum_k alpha_k U_k |x> vanishes); "
            "the post-selected state is undefined"
        )
    return Statevector(amplitudes / math.sqrt(probability))
