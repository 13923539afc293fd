"""Oracle tests for decompositions into sub-unitaries (``qdensity.models.decompositions``).

Oracles: the ``Operator`` of the source circuit equals the ordered product of its layer-wise
sub-unitaries (paper Fig. 3 left, Fig. 6); commutators of generators assembled from dense Pauli
matrices (odd-even split, Supp. H.1 eq. 27); parameter counts from the paper's formulas
(round-robin of depth D: ``D n / 2`` per expert, K = n - 1; K copies: K times).
"""

from __future__ import annotations

import math
from functools import reduce
from itertools import combinations

import numpy as np
import pytest
from qiskit.circuit import ParameterVector, QuantumCircuit
from qiskit.quantum_info import Operator

from qdensity.circuits.ansatze import butterfly, hardware_efficient, pyramid, round_robin
from qdensity.models.decompositions import (
    by_moments,
    copies,
    cyclic_moments,
    independent,
    odd_even,
    trainable_parameters,
)

I2 = np.eye(2, dtype=complex)
X = np.array([[0, 1], [1, 0]], dtype=complex)
Y = np.array([[0, -1j], [1j, 0]], dtype=complex)


def dense(ops: dict[int, np.ndarray], n: int) -> np.ndarray:
    return reduce(np.kron, [ops.get(q, I2) for q in reversed(range(n))])


def rbs_generator(i: int, j: int, n: int) -> np.ndarray:
    return (dense({i: X, j: Y}, n) - dense({i: Y, j: X}, n)) / 2


def bind(circuit: QuantumCircuit, values: dict) -> QuantumCircuit:
    return circuit.assign_parameters({p: values[p] for p in circuit.parameters})


def random_values(circuit: QuantumCircuit, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    return {p: float(v) for p, v in zip(circuit.parameters,
                                         rng.uniform(-math.pi, math.pi, circuit.num_parameters),
                                         strict=True)}


def composed_operator(parts, values) -> Operator:
    op = Operator(np.eye(2**parts[0].num_qubits))
    for qc in parts:
        op = op.compose(Operator(bind(qc, values)))  # apply qc after what came before
    return op


def pairs_of(circuit: QuantumCircuit) -> list[tuple[int, ...]]:
    return [tuple(sorted(circuit.find_bit(q).index for q in inst.qubits)) for inst in circuit.data]


def assert_partition(parts, source):
    sets = [set(qc.parameters) for qc in parts]
    for a, b in combinations(sets, 2):
        assert not a & b
    assert set().union(*sets) == set(source.parameters)


@pytest.mark.parametrize("n", [4, 6])
def test_round_robin_by_moments(n):
    qc = round_robin(n)
    dec = by_moments(qc)
    assert dec.num_subunitaries == n - 1
    assert dec.independent
    assert dec.parameter_counts() == [n // 2] * (n - 1)
    assert dec.num_parameters == qc.num_parameters
    assert_partition(dec.sub_unitaries, qc)
    for part in dec.sub_unitaries:
        assert part.num_qubits == n
        used = [q for pair in pairs_of(part) for q in pair]
        assert sorted(used) == list(range(n))  # one perfect matching per layer
    for seed in range(2):
        values = random_values(qc, seed)
        assert composed_operator(dec.sub_unitaries, values).equiv(Operator(bind(qc, values)))


def test_by_moments_depth_groups_consecutive_layers():
    qc = round_robin(6)
    dec = by_moments(qc, depth=2)
    assert dec.num_subunitaries == 3
    assert dec.parameter_counts() == [6, 6, 3]
    values = random_values(qc, 5)
    assert composed_operator(dec.sub_unitaries, values).equiv(Operator(bind(qc, values)))
    with pytest.raises(ValueError, match="depth"):
        by_moments(qc, depth=6)
    with pytest.raises(ValueError, match="no parameterised gates"):
        by_moments(QuantumCircuit(2))


@pytest.mark.parametrize("n,reps", [(3, 2), (4, 3)])
@pytest.mark.parametrize("entanglement", ["ladder", "ring"])
def test_hardware_efficient_by_moments_keeps_ladders(n, reps, entanglement):
    qc = hardware_efficient(n, reps, rotations=("ry", "rx"), entanglement=entanglement)
    dec = by_moments(qc)
    assert dec.num_subunitaries == reps
    assert dec.parameter_counts() == [n] * reps
    assert_partition(dec.sub_unitaries, qc)
    params = list(qc.parameters)
    for d, part in enumerate(dec.sub_unitaries):
        assert set(part.parameters) == set(params[d * n:(d + 1) * n])
        # the ladder written out from the paper's Fig. 3: forward on even, backward on odd
        ladder = [(i, i + 1) for i in range(n - 1)]
        if entanglement == "ring" and n > 2:
            ladder.append((n - 1, 0))
        if d % 2:
            ladder = [(t, c) for c, t in reversed(ladder)]
        cx = [tuple(part.find_bit(q).index for q in inst.qubits)
              for inst in part.data if inst.operation.name == "cx"]
        assert cx == ladder
    values = random_values(qc, 3)
    assert composed_operator(dec.sub_unitaries, values).equiv(Operator(bind(qc, values)))


@pytest.mark.parametrize("n", [4, 8])
def test_butterfly_by_layers(n):
    qc = butterfly(n)
    dec = by_moments(qc)
    assert dec.num_subunitaries == int(math.log2(n))
    assert dec.parameter_counts() == [n // 2] * int(math.log2(n))
    values = random_values(qc, n)
    assert composed_operator(dec.sub_unitaries, values).equiv(Operator(bind(qc, values)))


@pytest.mark.parametrize("n", [4, 5, 6])
def test_odd_even_pyramid(n):
    qc = pyramid(n)
    dec = odd_even(qc)
    assert dec.num_subunitaries == 2
    assert dec.independent
    assert_partition(dec.sub_unitaries, qc)
    assert dec.num_parameters == qc.num_parameters == n * (n - 1) // 2
    for parity, part in enumerate(dec.sub_unitaries):
        pairs = pairs_of(part)
        assert all(i % 2 == parity for i, _ in pairs)
        gens = [rbs_generator(i, j, n) for i, j in pairs]
        for a, b in combinations(gens, 2):
            assert np.abs(a @ b - b @ a).max() < 1e-14
    # the two halves do not commute with each other (the split is not trivial)
    g_even = rbs_generator(*pairs_of(dec.sub_unitaries[0])[0], n)
    g_odd = rbs_generator(*pairs_of(dec.sub_unitaries[1])[0], n)
    assert np.abs(g_even @ g_odd - g_odd @ g_even).max() > 0.1


@pytest.mark.parametrize("n,depth", [(4, 1), (4, 2), (6, 2), (6, 5)])
def test_cyclic_moments_round_robin(n, depth):
    qc = round_robin(n)
    dec = cyclic_moments(qc, depth)
    k = n - 1
    assert dec.num_subunitaries == k
    assert dec.independent
    assert dec.parameter_counts() == [depth * n // 2] * k
    assert dec.num_parameters == k * depth * n // 2
    sets = [set(part.parameters) for part in dec.sub_unitaries]
    for a, b in combinations(sets, 2):
        assert not a & b
    assert not set().union(*sets) & set(qc.parameters)
    # sub-unitary j holds source layers j .. j + depth - 1 (mod n - 1), in that order
    layers = [pairs_of(part) for part in by_moments(qc).sub_unitaries]
    for j, part in enumerate(dec.sub_unitaries):
        expected = [pair for m in range(depth) for pair in layers[(j + m) % k]]
        assert pairs_of(part) == expected
    # the last expert of a full-depth decomposition is a rotated copy of the source
    if depth == k:
        first = dec.sub_unitaries[0]
        values = random_values(qc, 1)
        renamed = dict(zip(first.parameters, values.values(), strict=True))
        assert Operator(first.assign_parameters(renamed)).equiv(Operator(bind(qc, values)))
    with pytest.raises(ValueError, match="depth"):
        cyclic_moments(qc, k + 1)


def test_copies_and_independent():
    x = ParameterVector("x", 2)
    theta = ParameterVector("θ", 3)
    qc = QuantumCircuit(2)
    qc.ry(x[0], 0)
    qc.ry(x[1], 1)
    qc.rx(theta[0], 0)
    qc.cx(0, 1)
    qc.ry(theta[1], 1)
    qc.rz(theta[2], 0)
    dec = copies(qc, 4)
    assert dec.num_subunitaries == 4
    assert dec.source is qc
    assert dec.independent
    assert dec.num_parameters == 4 * 3
    assert dec.parameter_counts() == [3] * 4
    own = [set(trainable_parameters(part)) for part in dec.sub_unitaries]
    for a, b in combinations(own, 2):
        assert not a & b
    values = random_values(qc, 0)
    for part in dec.sub_unitaries:
        assert set(x) <= set(part.parameters)  # data parameters are shared, not copied
        mapping = {p: values[p] for p in x}
        mapping.update(dict(zip(trainable_parameters(part),
                                [values[t] for t in theta], strict=True)))
        assert Operator(part.assign_parameters(mapping)).equiv(Operator(bind(qc, values)))
    assert trainable_parameters(qc) == list(theta)
    with pytest.raises(ValueError, match="num_copies"):
        copies(qc, 0)
    with pytest.raises(ValueError, match="circuits must be a list or tuple of 1 to"):
        independent([])
    with pytest.raises(TypeError, match=r"circuits\[1\]"):
        independent([qc, "nope"])
    assert independent([pyramid(3), round_robin(3)]).num_parameters == 6


def test_sub_unitary_names_are_stable():
    """No Qiskit instance counter ("-50") in the names: the same call names the same."""
    import re

    from qdensity.circuits.ansatze import pyramid as _pyramid
    from qdensity.models.decompositions import cyclic_moments as _cyclic
    from qdensity.models.decompositions import independent as _independent

    for dec in (_cyclic(_pyramid(4), 2), _independent([_pyramid(4), _pyramid(4)])):
        names = [c.name for c in dec.sub_unitaries]
        assert not any(re.search(r"-\d+$", n) for n in names), names
    assert [c.name for c in _cyclic(_pyramid(4), 2).sub_unitaries][:2] == [
        "pyramid_4_cyclic2_0", "pyramid_4_cyclic2_1"]
