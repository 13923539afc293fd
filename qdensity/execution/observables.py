"""Observables read off computational-basis measurements: Z-string parities, the eigenvalues of
a diagonal observable on each outcome, the single-qubit rotations that make a qubit-wise
commuting group diagonal, and the check every observable argument goes through.

A measured outcome is the integer ``b = sum_j b_j 2^j`` (qubit ``j`` into clbit ``j``), as in
:mod:`qdensity.execution.plans`.
"""

from __future__ import annotations

import numpy as np
from qiskit.circuit import QuantumCircuit
from qiskit.quantum_info import PauliList, SparsePauliOp

from qdensity.validation import check_width

__all__ = ["z_parities", "diagonal_values", "basis_rotation", "check_observable"]


def z_parities(z_masks: np.ndarray, num_bits: int) -> np.ndarray:
    """Signs ``(-1)^{popcount(b & mask)}`` for every outcome ``b`` and every mask.

    Parameters
    ----------
    z_masks : numpy.ndarray of int, shape (T,)
        Bit masks of the Z supports.
    num_bits : int

    Returns
    -------
    numpy.ndarray, shape (T, 2**num_bits), entries +-1

    Examples
    --------
    >>> z_parities(np.array([0b01, 0b11]), 2).tolist()  # Z_0 and Z_0 Z_1 on b = 0, 1, 2, 3
    [[1.0, -1.0, 1.0, -1.0], [1.0, -1.0, -1.0, 1.0]]
    """
    check_width(num_bits, engine="z_parities (a dense 2**n table)", rows=max(np.size(z_masks), 1),
                alternative="the measured bits' parities (sampling)")
    outcomes = np.arange(2**num_bits, dtype=np.int64)
    anded = outcomes[None, :] & np.asarray(z_masks, dtype=np.int64)[:, None]
    parity = np.zeros_like(anded)
    for bit in range(num_bits):
        parity ^= (anded >> bit) & 1
    return 1.0 - 2.0 * parity


def diagonal_values(paulis: PauliList, coeffs: np.ndarray, num_bits: int) -> np.ndarray:
    """Eigenvalue of ``sum_t c_t P_t`` on each outcome, for diagonal (I/Z, phase +-1) ``P_t``.

    Parameters
    ----------
    paulis : PauliList
        Z-type Paulis (no X part); their phases are included.
    coeffs : numpy.ndarray, shape (T,)
        Real coefficients.
    num_bits : int

    Returns
    -------
    numpy.ndarray, shape (2**num_bits,)

    Examples
    --------
    >>> diagonal_values(PauliList(["IZ", "ZZ"]), np.array([1.0, 0.5]), 2).tolist()
    [1.5, -1.5, 0.5, -0.5]
    """
    if np.any(paulis.x):
        raise ValueError("diagonal_values needs Z-type Paulis (no X or Y part)")
    masks = (paulis.z.astype(np.int64) * (1 << np.arange(paulis.num_qubits))).sum(axis=1)
    signs = (-1j) ** paulis.phase
    coeff = np.real(np.asarray(coeffs) * signs)
    return coeff @ z_parities(masks, num_bits)


def basis_rotation(paulis: PauliList) -> tuple[QuantumCircuit, PauliList]:
    """Single-qubit rotations that map qubit-wise commuting Paulis to Z strings.

    Parameters
    ----------
    paulis : PauliList
        Qubit-wise commuting Paulis.

    Returns
    -------
    (QuantumCircuit, PauliList)
        The rotation (H for X, Sdg then H for Y) and the Z-type images.

    Examples
    --------
    >>> rotation, images = basis_rotation(PauliList(["XI", "XZ"]))
    >>> dict(rotation.count_ops()), images.to_labels()
    ({'h': 1}, ['ZI', 'ZZ'])
    """
    n = paulis.num_qubits
    qc = QuantumCircuit(n)
    xs, zs = paulis.x.any(axis=0), paulis.z.any(axis=0)
    for q in range(n):
        kinds = {(bool(x), bool(z)) for x, z in zip(paulis.x[:, q], paulis.z[:, q], strict=True)}
        kinds.discard((False, False))
        if len(kinds) > 1:
            raise ValueError(f"Paulis are not qubit-wise commuting on qubit {q}")
        if xs[q] and zs[q]:
            qc.sdg(q)
            qc.h(q)
        elif xs[q]:
            qc.h(q)
    images = PauliList.from_symplectic(paulis.x | paulis.z, np.zeros_like(paulis.x))
    return qc, images


def check_observable(observable, num_qubits: int, name: str = "observable") -> SparsePauliOp:
    """A Hermitian ``SparsePauliOp`` on ``num_qubits`` qubits, or a ``ValueError``.

    Examples
    --------
    >>> check_observable("ZZ", 3)
    Traceback (most recent call last):
    ValueError: observable acts on 2 qubits but the circuit has 3
    """
    if not isinstance(observable, SparsePauliOp):
        try:
            observable = SparsePauliOp(observable)
        except Exception as exc:
            raise TypeError(
                f"{name} must be a SparsePauliOp or a Pauli label, got {observable!r}"
            ) from exc
    if observable.num_qubits != num_qubits:
        raise ValueError(
            f"{name} acts on {observable.num_qubits} qubits but the circuit has {num_qubits}"
        )
    if not np.allclose(observable.coeffs.imag, 0.0, atol=1e-12):
        raise ValueError(f"{name} must be Hermitian (real Pauli coefficients)")
    return observable
