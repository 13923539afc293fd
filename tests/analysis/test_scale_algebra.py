"""GF(2) commutation and outcome tables against independent oracles (issue: scale)."""

from __future__ import annotations

import numpy as np
import pytest
from qiskit.quantum_info import Pauli, PauliList, SparsePauliOp, random_pauli_list

from qdensity.analysis.pauli import (
    MAX_DENSE_QUBITS,
    ZStringTable,
    anticommutation,
    z_string_values,
)


def test_anticommutation_matches_pairwise_qiskit():
    a = random_pauli_list(9, 40, seed=1, phase=False)
    b = random_pauli_list(9, 25, seed=2, phase=False)
    got = anticommutation(a.x, a.z, b.x, b.z)
    want = np.array([[not Pauli(p).commutes(Pauli(q)) for q in b] for p in a])
    np.testing.assert_array_equal(got, want)
    square = anticommutation(a.x, a.z)
    np.testing.assert_array_equal(square, square.T)
    assert not square.diagonal().any()


def test_table_on_bits_and_dense_match_operator_diagonals():
    ops = [SparsePauliOp(["ZIZ", "IZI"], [0.5, -2.0]), SparsePauliOp(["-ZZZ", "III"], [1.0, 3.0])]
    table = ZStringTable.from_operators(ops, 3)
    dense = table.dense()
    for col, op in enumerate(ops):  # oracle: the diagonal of the operator's matrix
        np.testing.assert_allclose(dense[:, col], np.real(np.diag(op.to_matrix())), atol=1e-12)
    bits = np.array([[1, 0, 1], [0, 1, 1]], dtype=bool)
    ints = bits.astype(int) @ (1 << np.arange(3))
    np.testing.assert_allclose(table.on_bits(bits), dense[ints])
    # against the older tabulation z_string_values as a second oracle
    zv = z_string_values(PauliList(["ZIZ", "IZI"]), 3)
    np.testing.assert_allclose(dense[:, 0], zv @ np.array([0.5, -2.0]))


def test_ancilla_z_doubles_the_table():
    table = ZStringTable(np.array([[True, False]]), np.array([[1.0, 2.0]]))
    wide = table.with_ancilla_z(-3.0).dense()
    base = table.dense()
    np.testing.assert_allclose(wide[:4], -3.0 * base)
    np.testing.assert_allclose(wide[4:], 3.0 * base)


def test_dense_refused_above_documented_width():
    table = ZStringTable(np.zeros((1, MAX_DENSE_QUBITS + 1), bool), np.ones((1, 1)))
    with pytest.raises(ValueError, match="MAX_DENSE_QUBITS"):
        table.dense()
    # on bits it works at any width
    bits = np.ones((3, MAX_DENSE_QUBITS + 1), bool)
    np.testing.assert_allclose(table.on_bits(bits), np.ones((3, 1)))
