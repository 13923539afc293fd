"""The shortcuts of the density-gradient plan build against independent constructions: the
RBS layer appended onto the gradient circuit (against Qiskit's ``compose``), the moment test
of commuting generators (against exact matrix commutators), parameter rows from mixed columns
(against columns placed one by one) and the analysis key of an encoded circuit (the encoding
is part of it)."""

from __future__ import annotations

import numpy as np
import pytest
from qiskit import QuantumCircuit
from qiskit.circuit import Parameter, ParameterVector
from qiskit.quantum_info import Operator, SparsePauliOp

from qdensity import DensityQNN, Encoding, by_moments
from qdensity.analysis.blocks import _first_noncommuting, _trainable_of
from qdensity.circuits.ansatze import round_robin
from qdensity.circuits.gates import RBSGate
from qdensity.circuits.measure import measured
from qdensity.gradients import density_gradient_plan
from qdensity.gradients.commuting import _one_block
from qdensity.gradients.diagonalising import _measured_rbs, rbs_diagonalising_layer
from qdensity.models._rows import bind_rows

RNG = np.random.default_rng(11)


@pytest.mark.parametrize("pairs", [[(0, 1), (2, 3)], [(3, 0), (1, 4)], []])
def test_rbs_layer_on_the_copy_equals_the_composed_layer(pairs):
    theta = ParameterVector("t", 3)
    circ = QuantumCircuit(5)
    circ.append(RBSGate(theta[0]), [0, 1])
    circ.append(RBSGate(theta[1]), [2, 3])
    circ.append(RBSGate(theta[2]), [1, 4])
    expected = circ.copy()
    if pairs:
        expected.barrier()
        expected.compose(rbs_diagonalising_layer(5, pairs), inplace=True)
    expected = measured(expected)
    got = _measured_rbs(circ, pairs)
    assert got == expected
    # its symbolic gates are its own: binding it in place leaves the source untouched
    got.assign_parameters(dict.fromkeys(theta, 0.3), inplace=True)
    assert circ.num_parameters == 3
    assert all(inst.operation.params[0] in set(theta) for inst in circ.data)


def _commute_exactly(a, b) -> bool:
    ma, mb = Operator(a).data, Operator(b).data
    return np.allclose(ma @ mb, mb @ ma, atol=1e-10)


@pytest.mark.parametrize("layout, commute", [
    ([(0, 1), (2, 3), (4, 5)], True),   # one moment: disjoint supports
    ([(0, 1), (0, 1)], True),           # the same generator twice
    ([(0, 1), (1, 2)], False),          # overlapping RBS gates do not commute
    ([(0, 1), (2, 3), (3, 4)], False),
])
def test_first_noncommuting_pair_matches_exact_commutators(layout, commute):
    n = 6
    params = [Parameter(f"p{i}") for i in range(len(layout))]
    circ = QuantumCircuit(n)
    for p, (a, b) in zip(params, layout, strict=True):
        circ.append(RBSGate(p), [a, b])
    # generators read one gate at a time (independent of the block's stacked terms)
    gens = []
    for i, p in enumerate(params):
        single = QuantumCircuit(n)
        single.append(RBSGate(p), list(layout[i]))
        gens.append(_trainable_of(single.data[0], single, 0, {p}).generator)
    exact = [(a, b) for a in range(len(gens)) for b in range(a + 1, len(gens))
             if not _commute_exactly(gens[a], gens[b])]
    assert (not exact) is commute
    assert _first_noncommuting(gens) == (exact[0] if exact else None)


def test_one_block_of_a_moment_after_a_loader_reads_every_gate_of_the_moment():
    n = 6
    subs = by_moments(round_robin(n)).sub_unitaries
    model = DensityQNN(subs, encoding=Encoding.unary(n), readout="unary_probabilities", seed=0)
    total = SparsePauliOp.from_sparse_list([("Z", [j], 1.0) for j in range(n)], n)
    for k in range(model.num_subunitaries):
        circ = model.circuit(k)
        params = list(subs[k].parameters)
        _, _, trainables = _one_block(circ, total, params, "auto")
        loader = len(model.encoding.circuit.data)
        assert [t.index for t in trainables] == list(range(loader, circ.size()))
        assert [t.parameter for t in trainables] == [i.operation.params[0]
                                                     for i in subs[k].data]


def test_bind_rows_places_mixed_columns_as_one_by_one():
    ps = [Parameter(f"q{i}") for i in range(7)]
    circ = QuantumCircuit(1)
    for p in ps:
        circ.rz(p, 0)
    B = 4
    columns = {
        ps[0]: RNG.normal(size=B),                      # full float column
        ps[1]: 0.25,                                    # Python float
        ps[2]: np.float32(1.5),                         # NumPy float scalar
        ps[3]: np.array([2.0]),                         # a (1,) column, broadcast
        ps[4]: 3,                                       # an int
        ps[5]: RNG.normal(size=B).astype(np.float32),   # float32 column
        ps[6]: np.arange(B),                            # an integer column
    }
    ps.append(Parameter("q7"))
    circ.rz(ps[7], 0)
    columns[ps[7]] = np.array([0.5, 1.5])[..., 1]      # a 0-d float array (theta[..., i])
    expected = np.empty((B, len(ps)))
    for i, p in enumerate(circ.parameters):
        expected[:, i] = np.broadcast_to(np.asarray(columns[p], dtype=float).reshape(-1), B)
    np.testing.assert_array_equal(bind_rows(circ, columns), expected)
    with pytest.raises(ValueError, match="q1 have shape"):
        bind_rows(circ, {**columns, ps[1]: np.zeros(B - 2)})


def test_analysis_key_of_an_encoded_circuit_holds_the_encoding():
    """Equal sub-unitaries behind different loaders are different structures: their gradient
    circuits are not shared (while equal models share them, see test_plan_scaling)."""
    n = 4
    subs = by_moments(round_robin(n)).sub_unitaries
    obs = SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], n)
    unary = DensityQNN(subs, encoding=Encoding.unary(n), observable=obs, seed=0)
    angle = DensityQNN(subs, encoding=Encoding.angle(n), observable=obs, seed=0)
    X = RNG.normal(size=(1, n))
    a = density_gradient_plan(unary, X, method="commuting")
    b = density_gradient_plan(angle, X, method="commuting")
    for ja, jb in zip(a.jobs, b.jobs, strict=True):
        if ja.label.startswith("commuting"):
            assert ja.circuit is not jb.circuit
            assert ja.circuit != jb.circuit


def test_gc_paused_restores_the_collector_state():
    import gc

    from qdensity.circuits._copying import gc_paused

    assert gc.isenabled()
    with gc_paused():
        assert not gc.isenabled()
        with gc_paused():  # nested: still off after the inner one ends
            pass
        assert not gc.isenabled()
    assert gc.isenabled()
    with pytest.raises(RuntimeError), gc_paused():
        raise RuntimeError("inside")
    assert gc.isenabled()
    gc.disable()
    try:
        with gc_paused():
            pass
        assert not gc.isenabled()  # off on entry: left off
    finally:
        gc.enable()
