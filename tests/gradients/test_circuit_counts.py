"""Gradient-circuit counts without the circuits, against the plans that build them.

Oracle: ``density_gradient_plan(model, method=m, forward=False).meta["gradient_circuits"]``
(the plans' counts are themselves checked against the paper's Table 1 statements in
tests/experiments/test_table1.py and their circuits against finite differences elsewhere).
"""

import re

import numpy as np
import pytest
from qiskit import QuantumCircuit
from qiskit.circuit import Parameter
from qiskit.quantum_info import SparsePauliOp

from qdensity.circuits.ansatze import (
    butterfly,
    equivariant_commuting,
    hardware_efficient,
    pyramid,
    round_robin,
)
from qdensity.gradients import (
    commuting_gradient,
    commuting_gradient_count,
    density_gradient_plan,
    gradient_circuit_count,
    parameter_shift_plan,
    shift_circuit_count,
)
from qdensity.models.decompositions import by_moments, copies, odd_even
from qdensity.models.density import DensityQNN
from qdensity.models.encoding import Encoding


def _z(n, qubits, coeffs=None):
    coeffs = coeffs or [1.0] * len(qubits)
    return SparsePauliOp.from_sparse_list([("Z", [q], c) for q, c in zip(qubits, coeffs,
                                                                         strict=True)], n)


def _models(n):
    he = hardware_efficient(n, 2)
    rr, py = round_robin(n), pyramid(n)
    eq = equivariant_commuting(n, "X")
    mixed = SparsePauliOp.from_sparse_list([("X", [0], 0.5), ("Z", [1], 0.3), ("", [], 1.0)], n)
    out = [
        DensityQNN([he], observable=_z(n, [0])),
        DensityQNN([he], observable=_z(n, range(n))),
        DensityQNN([he], observable=mixed),
        DensityQNN(by_moments(he).sub_unitaries, observable=_z(n, range(n))),
        DensityQNN([rr], observable=_z(n, range(n))),
        DensityQNN(by_moments(rr).sub_unitaries, observable=_z(n, range(n))),
        DensityQNN(odd_even(py).sub_unitaries, observable=_z(n, [0, 1], [0.7, -0.2])),
        DensityQNN([eq], observable=_z(n, [0])),
        DensityQNN(copies(eq, 2).sub_unitaries, observable=_z(n, [0])),
        DensityQNN(copies(eq, 2).sub_unitaries, observable=mixed),
        DensityQNN(by_moments(rr).sub_unitaries, encoding=Encoding.unary(n),
                   readout="unary_probabilities"),
        DensityQNN([py], encoding=Encoding.unary(n), observable=_z(n, [0])),
    ]
    if n & (n - 1) == 0:
        out.append(DensityQNN(by_moments(butterfly(n)).sub_unitaries, observable=_z(n, [0])))
    return out


@pytest.mark.parametrize("n", [4, 5])
@pytest.mark.parametrize("method", ["auto", "shift", "commuting"])
def test_counts_equal_the_plans(n, method):
    checked = []
    for i, model in enumerate(_models(n)):
        X = None if model.encoding is None else np.random.default_rng(i).normal(size=(2, n))
        try:
            plan = density_gradient_plan(model, X, method=method, forward=False)
        except ValueError as exc:  # the count raises what the plan raises
            with pytest.raises(ValueError, match=re.escape(str(exc)[:40])):
                gradient_circuit_count(model, method=method)
            continue
        assert gradient_circuit_count(model, method=method) == plan.meta["gradient_circuits"], i
        checked.append(i)
    assert len(checked) >= 8  # most models take every method


def test_one_block_and_shift_counts_equal_the_built_objects():
    n = 4
    qc = hardware_efficient(n, 1)
    for obs in (_z(n, [0]), _z(n, range(n)),
                SparsePauliOp.from_sparse_list([("X", [0], 1.0), ("Y", [1], 1.0)], n)):
        for diag in ("auto", "clifford"):
            try:
                built = commuting_gradient(qc, obs, diagonaliser=diag).num_gradient_circuits
            except ValueError:
                continue
            assert commuting_gradient_count(qc, obs, diagonaliser=diag) == built
        rows = np.zeros((3, qc.num_parameters))
        assert shift_circuit_count(qc, obs) * 3 == parameter_shift_plan(qc, obs, rows).num_circuits
    assert shift_circuit_count(qc, None) * 3 == parameter_shift_plan(qc, None, rows).num_circuits
    moment = by_moments(round_robin(n)).sub_unitaries[0]
    assert commuting_gradient_count(moment, _z(n, range(n)), diagonaliser="rbs") == 1
    a = Parameter("a")
    ry = QuantumCircuit(2)
    ry.ry(a, 0)
    with pytest.raises(ValueError, match="diagonaliser='rbs' needs RBS"):
        commuting_gradient_count(ry, _z(2, [0]), diagonaliser="rbs")
    with pytest.raises(ValueError, match="method must be one of"):
        gradient_circuit_count(DensityQNN([ry], observable=_z(2, [0])), method="adjoint")
