"""The ansatz-family and model registries: each entry against the circuits it builds, and a
family registered in one place (here, in the test) usable from the estimators, their saved
files, ``qdensity build`` and ``qdensity sweep`` with no other edit.

Oracles: the built circuit's ``num_parameters`` (never the declared formula), the builder's own
refusal of a size, the gradient methods and readouts the upper layers define, and for the toy
family its matrix written out from the paper's RBS matrix.
"""

from __future__ import annotations

import argparse
import math

import numpy as np
import pytest
from qiskit.circuit import ParameterVector, QuantumCircuit
from qiskit.quantum_info import Operator

from qdensity.circuits.ansatze.registry import (
    FAMILIES,
    AnsatzFamily,
    estimator_ansatze,
    register_family,
)
from qdensity.circuits.gates import RBSGate
from qdensity.gradients.density import METHODS
from qdensity.models.density import READOUTS
from qdensity.models.registry import DECOMPOSITIONS, MIXTURES

SIZES = range(1, 10)


def _builds(family: AnsatzFamily, n: int) -> QuantumCircuit | None:
    try:
        return family.builder(n)
    except ValueError:
        return None


@pytest.mark.parametrize("name", list(FAMILIES))
def test_parameter_count_and_sizes_are_the_built_circuits(name):
    family = FAMILIES[name]
    built_any = False
    for n in SIZES:
        circuit = _builds(family, n)
        assert family.accepts(n) == (circuit is not None), (name, n)
        if circuit is not None:
            built_any = True
            assert family.parameter_count(n) == circuit.num_parameters, (name, n)
    assert built_any


@pytest.mark.parametrize("name", list(FAMILIES))
def test_gradient_rule_and_readouts_name_what_the_upper_layers_define(name):
    family = FAMILIES[name]
    assert family.gradient in METHODS and family.gradient != "auto"
    assert family.readouts is None or (family.readouts
                                       and set(family.readouts) <= set(READOUTS))
    if family.estimator:  # saved files refuse huge specs before building: a declared count
        assert family.num_parameters is not None


def test_the_estimator_families_are_the_weight_preserving_ones():
    from qdensity.analysis.structure import is_hamming_weight_preserving

    for name in estimator_ansatze():
        assert is_hamming_weight_preserving(FAMILIES[name].builder(4)), name


def test_a_name_is_registered_once():
    with pytest.raises(ValueError, match="family: an ansatz family named 'pyramid'"):
        register_family(AnsatzFamily("pyramid", FAMILIES["pyramid"].builder))
    with pytest.raises(ValueError, match="'x_circuit'"):  # the command-line name is taken too
        register_family(AnsatzFamily("x_circuit", FAMILIES["x"].builder))
    with pytest.raises(ValueError, match="must declare num_parameters"):
        register_family(AnsatzFamily("untold", FAMILIES["x"].builder, estimator=True))
    assert "untold" not in FAMILIES


@pytest.mark.parametrize("name", list(DECOMPOSITIONS))
def test_decompositions_count_the_angles_of_the_models_they_make(name):
    kind = DECOMPOSITIONS[name]
    circuit = FAMILIES["round_robin"].builder(4)
    for depth in (1, 2, 3):
        subs = kind.split(circuit, depth)
        angles = len({p for sub in subs for p in sub.parameters})
        declared = kind.num_angles(circuit.num_parameters, depth)
        # every angle counted (cyclic: an upper bound, its depth is capped by the moments)
        assert angles == declared if not kind.angle_copies else angles <= declared


@pytest.mark.parametrize("name", list(MIXTURES))
def test_mixtures_give_a_distribution_over_the_sub_unitaries(name):
    kind = MIXTURES[name]
    mixture = kind.build(3, 4, 0)
    if mixture is None:  # the model's default: uniform and fixed
        assert name == "fixed"
        return
    X = np.random.default_rng(1).normal(size=(5, 3))
    alpha = np.asarray(mixture.alpha(X if kind.data_dependent else None))
    rows = alpha if alpha.ndim == 2 else alpha[None]
    np.testing.assert_allclose(rows.sum(axis=1), 1.0, atol=1e-12)
    assert np.all(rows >= 0) and rows.shape[-1] == 4
    if kind.from_alpha is not None:
        start = kind.from_alpha(np.array([0.7, 0.1, 0.1, 0.1]))
        np.testing.assert_allclose(np.ravel(start.alpha(None)), [0.7, 0.1, 0.1, 0.1], atol=1e-12)


# ---- a toy family, registered here only --------------------------------------------------

TOY = "toy_ladder"


def _ladder(num_qubits: int) -> QuantumCircuit:
    """RBS on (0, 1), (1, 2), ...: n - 1 angles."""
    if num_qubits < 2:
        raise ValueError(f"num_qubits must be at least 2, got {num_qubits}")
    theta = ParameterVector("t", num_qubits - 1)
    qc = QuantumCircuit(num_qubits)
    for i in range(num_qubits - 1):
        qc.append(RBSGate(theta[i]), [i, i + 1])
    return qc


def _ladder_unary(angles) -> np.ndarray:
    """The toy circuit on unary amplitudes: Givens rotations by +theta, written out."""
    n = len(angles) + 1
    out = np.eye(n)
    for i, t in enumerate(angles):
        g = np.eye(n)
        g[i, i] = g[i + 1, i + 1] = math.cos(t)
        g[i, i + 1], g[i + 1, i] = -math.sin(t), math.sin(t)
        out = g @ out
    return out


@pytest.fixture
def toy():
    family = register_family(AnsatzFamily(TOY, _ladder, lambda n: n - 1,
                                          readouts=("unary_probabilities", "observable"),
                                          estimator=True))
    yield family
    FAMILIES.pop(TOY)


def test_a_toy_family_is_an_estimator_ansatz_with_its_saved_file(toy, tmp_path):
    from qdensity.learning.estimators import QNNClassifier

    rng = np.random.default_rng(7)
    X = rng.normal(size=(16, 3))
    y = (X[:, 0] > 0).astype(int)
    est = QNNClassifier(ansatz=TOY, decomposition="none", num_qubits=4, epochs=1,
                        batch_size=8, verbose=False, readout="unary_probabilities").fit(X, y)
    (sub,) = est.model_.sub_unitaries
    assert sub.num_parameters == 3
    angles = rng.uniform(-np.pi, np.pi, 3)
    bound = sub.assign_parameters(angles)
    # the estimator's circuit is the toy's: its unary block is the written-out product
    unary = Operator(bound).data[np.ix_([1, 2, 4, 8], [1, 2, 4, 8])]
    np.testing.assert_allclose(unary, _ladder_unary(angles), atol=1e-12)
    path = tmp_path / "toy.json"
    est.save(path)
    back = QNNClassifier().load(path)
    assert np.array_equal(back.predict_proba(X), est.predict_proba(X))
    with pytest.raises(ValueError, match="readout must be one of"):
        QNNClassifier(ansatz=TOY, num_qubits=4, epochs=1, readout="unary_amplitudes",
                      verbose=False).fit(X, y)


def test_a_toy_family_is_a_builder_and_a_sweep_choice(toy):
    from qdensity.cli import BUILDERS, build_circuit, main, sweep

    assert TOY in BUILDERS and TOY in list(BUILDERS)
    qc = build_circuit(TOY, 3, bind_seed=5)
    angles = np.random.default_rng(5).uniform(-np.pi, np.pi, 2)  # build's bound values
    unary = Operator(qc).data[np.ix_([1, 2, 4], [1, 2, 4])]
    np.testing.assert_allclose(unary, _ladder_unary(angles), atol=1e-12)
    assert main(["build", TOY, "--size", "3"]) == 0
    sub = argparse.ArgumentParser().add_subparsers()
    sweep.add_parser(sub, lambda lo, hi: int, int, 8)
    assert sub.choices["sweep"].parse_args(["--ansatz", TOY]).ansatz == TOY


def test_without_the_toy_family_its_name_is_refused():
    from qdensity.cli import BUILDERS, build_circuit
    from qdensity.learning.estimators import QNNClassifier

    assert TOY not in FAMILIES and TOY not in BUILDERS
    with pytest.raises(ValueError, match="unknown builder"):
        build_circuit(TOY, 3)
    with pytest.raises(ValueError, match="ansatz"):
        QNNClassifier(ansatz=TOY, verbose=False).fit(np.ones((4, 2)), [0, 1, 0, 1])


def test_table1_rows_are_registered_families_differentiated_as_the_paper_says():
    from qdensity.gradients.table1 import ANSATZE

    # paper Table 1: the equivariant circuit by commuting blocks, the others by shifts
    assert {name: FAMILIES[name].gradient for name in ANSATZE} == {
        "hardware_efficient": "shift", "equivariant_xx": "commuting", "pyramid": "shift",
        "butterfly": "shift", "round_robin": "shift"}
