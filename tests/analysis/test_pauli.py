"""Tests of qdensity.analysis.pauli against dense operator oracles."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from qiskit import transpile
from qiskit.quantum_info import Operator, Pauli, PauliList, SparsePauliOp, random_clifford
from qiskit_aer import AerSimulator

from qdensity.analysis.pauli import (
    commutation_matrix,
    conjugate_two_qubit,
    diagonalising_clifford,
    first_noncommuting_pair,
    paulis_commute_pairwise,
    z_string_values,
)
from qdensity.gradients.diagonalising import rbs_diagonalising_layer


def _random_commuting_set(n: int, m: int, seed: int) -> PauliList:
    """Random Z/I strings (random signs) conjugated by a random Clifford: a commuting set."""
    rng = np.random.default_rng(seed)
    z = rng.integers(0, 2, size=(m, n)).astype(bool)
    phase = 2 * rng.integers(0, 2, size=m)
    zs = PauliList.from_symplectic(z, np.zeros_like(z), phase)
    cliff = random_clifford(n, seed=seed)
    return zs.evolve(cliff, frame="s")


def _dense_z(p: Pauli) -> np.ndarray:
    assert not p.x.any()
    return p.to_matrix()


@settings(max_examples=25, deadline=None)
@given(
    n=st.integers(min_value=1, max_value=6),
    m=st.integers(min_value=1, max_value=8),
    seed=st.integers(min_value=0, max_value=10**6),
)
def test_diagonalising_clifford_oracle(n, m, seed):
    paulis = _random_commuting_set(n, m, seed)
    circ, z = diagonalising_clifford(paulis)
    assert set(circ.count_ops()) <= {"h", "s", "cx", "cz", "swap"}
    assert not z.x.any()
    u = Operator(circ).data
    for t in range(m):
        conj = u @ paulis[t].to_matrix() @ u.conj().T
        np.testing.assert_allclose(conj, _dense_z(z[t]), atol=1e-10)
        # Hermitian input keeps a +-1 phase, and the output is a genuine diagonal matrix.
        assert np.allclose(np.diag(np.diag(conj)), conj, atol=1e-10)


def test_diagonalising_clifford_transpiles_and_runs():
    paulis = _random_commuting_set(5, 6, seed=3)
    circ, _ = diagonalising_clifford(paulis)
    circ.measure_all()
    for basis in (["cz", "rz", "sx", "x"], ["cx", "rz", "sx", "x"]):
        tq = transpile(circ, basis_gates=basis, optimization_level=1, seed_transpiler=1)
        counts = AerSimulator(seed_simulator=1).run(tq, shots=16).result().get_counts()
        assert sum(counts.values()) == 16


def test_xx_yy_zz_bell_basis():
    circ, z = diagonalising_clifford(["XX", "YY", "ZZ"])
    u = Operator(circ).data
    for lab, zt in zip(["XX", "YY", "ZZ"], z, strict=True):
        np.testing.assert_allclose(
            u @ Pauli(lab).to_matrix() @ u.conj().T, zt.to_matrix(), atol=1e-12
        )


def test_noncommuting_pair_is_named():
    # ZI/ZZ commute, ZI/XX anticommute (one clash, on qubit 1), ZZ/XX commute
    with pytest.raises(ValueError, match=r"paulis\[0\] = ZI and paulis\[2\] = XX"):
        diagonalising_clifford(["ZI", "ZZ", "XX"])
    assert first_noncommuting_pair(["ZI", "ZZ", "XX"]) == (0, 2)
    assert paulis_commute_pairwise(["XX", "YY"])
    assert not paulis_commute_pairwise(["XY", "XX"])


def test_commutation_matrix_against_dense():
    pl = PauliList(["XYZ", "ZZI", "YIX", "IXY"])
    mat = commutation_matrix(pl)
    for s in range(4):
        for t in range(4):
            a, b = pl[s].to_matrix(), pl[t].to_matrix()
            assert mat[s, t] == (not np.allclose(a @ b, b @ a))


def test_z_string_values_against_dense_diagonal():
    pl = PauliList(["-ZIZ", "IZI", "ZZZ"])
    vals = z_string_values(pl)
    for t in range(3):
        np.testing.assert_allclose(vals[:, t], np.diag(pl[t].to_matrix()).real)
    with pytest.raises(ValueError, match="diagonal"):
        z_string_values(["XZ"])


@pytest.mark.parametrize("pairs", [[(0, 1)], [(0, 3), (1, 2)], [(2, 0)]])
def test_rbs_layer_diagonalises_xx_plus_yy(pairs):
    n = 4
    u = Operator(rbs_diagonalising_layer(n, pairs)).data
    for i, j in pairs:
        op = SparsePauliOp.from_sparse_list([("XX", [i, j], 1.0), ("YY", [i, j], 1.0)], n)
        conj = u @ op.to_matrix() @ u.conj().T
        assert np.allclose(conj, np.diag(np.diag(conj)), atol=1e-12)
        # Z_j - Z_i up to the overall sign fixed by the pair's orientation
        target = SparsePauliOp.from_sparse_list([("Z", [j], 1.0), ("Z", [i], -1.0)], n)
        assert np.allclose(np.abs(np.diag(conj)), np.abs(np.diag(target.to_matrix())))


def test_rbs_layer_rejects_bad_pairs():
    with pytest.raises(ValueError, match="disjoint"):
        rbs_diagonalising_layer(4, [(0, 1), (1, 2)])
    with pytest.raises(ValueError, match="two different qubits"):
        rbs_diagonalising_layer(3, [(0, 3)])


def test_conjugate_two_qubit_against_dense():
    rng = np.random.default_rng(7)
    n = 4
    labels = ["".join(rng.choice(list("IXYZ"), n)) for _ in range(6)]
    op = SparsePauliOp(labels, rng.normal(size=6))
    from qiskit.quantum_info import random_unitary

    u2 = random_unitary(4, seed=5)
    out = conjugate_two_qubit(op, u2, (3, 1))
    full = Operator(u2).data
    from qiskit import QuantumCircuit

    qc = QuantumCircuit(n)
    qc.unitary(full, [3, 1])
    big = Operator(qc).data
    np.testing.assert_allclose(
        out.to_matrix(), big @ op.to_matrix() @ big.conj().T, atol=1e-10
    )
