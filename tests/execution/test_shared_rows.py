"""Parameter rows held as a block shared by many jobs and a block of their own (SharedRows):
read back, they are the rows placed column by column here; a density-gradient plan's jobs
built on read share ``V(x)``'s block, and their rows read back equal the model's own rows
(``DensityQNN.rows``); drawn from shared rows, the shots are those of the same jobs holding
plain arrays."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest

from qdensity import DensityQNN, Encoding, SamplerEngine, by_moments
from qdensity.circuits.ansatze import round_robin
from qdensity.execution._lazy_jobs import LazyCircuitJob, SharedRows
from qdensity.gradients import density_gradient_plan

RNG = np.random.default_rng(71)


def _placed(shared, at, own) -> np.ndarray:
    """The rows written one column at a time: shared column j at at[j], own columns in the
    remaining places in order."""
    B, P = shared.shape[0], shared.shape[1] + own.shape[1]
    out = np.full((B, P), np.nan)
    for j, c in enumerate(at):
        out[:, c] = shared[:, j]
    rest = iter(range(own.shape[1]))
    for c in range(P):
        if c not in set(at):
            out[:, c] = own[:, next(rest)]
    return out


@pytest.mark.parametrize("B, L, extra", [(1, 1, 0), (3, 4, 2), (5, 0, 3), (2, 6, 6)])
def test_full_rows_are_the_blocks_placed_column_by_column(B, L, extra):
    at = RNG.permutation(L + extra)[:L]
    shared, own = RNG.normal(size=(B, L)), RNG.normal(size=(B, extra))
    rows = SharedRows(shared, at, own)
    expected = _placed(shared, at, own)
    np.testing.assert_array_equal(rows.full(), expected)
    np.testing.assert_array_equal(np.asarray(rows), expected)
    assert rows.shape == expected.shape and rows.shared is shared
    back = SharedRows.split(expected, shared, at)
    assert back is not None and back.shared is shared
    np.testing.assert_array_equal(back.full(), expected)
    np.testing.assert_array_equal(pickle.loads(pickle.dumps(rows)).full(), expected)


def test_split_refuses_rows_whose_columns_are_not_the_block():
    rows = RNG.normal(size=(3, 5))
    assert SharedRows.split(rows, rows[:, [1, 3]] + 1e-12, [1, 3]) is None
    assert SharedRows.split(rows[:2], rows[:, [1, 3]], [1, 3]) is None
    with pytest.raises(ValueError, match="repeats"):
        SharedRows(np.zeros((1, 2)), [0, 0], np.zeros((1, 1)))
    with pytest.raises(ValueError, match="columns in"):
        SharedRows(np.zeros((1, 2)), [0, 3], np.zeros((1, 1)))
    with pytest.raises(ValueError, match="blocks"):
        SharedRows(np.zeros((2, 2)), [0, 1], np.zeros((1, 1)))


def _model(n: int) -> DensityQNN:
    return DensityQNN(by_moments(round_robin(n)).sub_unitaries, encoding=Encoding.unary(n),
                      readout="unary_probabilities", seed=0)


@pytest.mark.parametrize("n", [4, 7])
def test_plan_jobs_share_the_loader_block_and_read_back_the_model_rows(n):
    model = _model(n)
    X = RNG.normal(size=(3, n))
    plan = density_gradient_plan(model, X, method="commuting", shots=50)
    K = model.num_subunitaries
    held = [job.held_rows for job in plan.jobs]
    assert all(isinstance(rows, SharedRows) for rows in held)
    assert len({id(rows.shared) for rows in held}) == 1  # one loader block per plan
    assert held[0].shared.shape == (3, n - 1)  # V(x): n - 1 angles
    for k in range(K):  # the gradient job and the forward job of sub-unitary k
        for job in (plan.jobs[k], plan.jobs[K + k]):
            np.testing.assert_array_equal(job.values, model.rows(k, X))
            assert job.rows == 3
    for job in (copy.deepcopy(plan.jobs[0]), plan.jobs[0].with_shots(9),
                pickle.loads(pickle.dumps(plan.jobs[0]))):
        assert isinstance(job.held_rows, SharedRows)
        np.testing.assert_array_equal(job.values, model.rows(0, X))


def test_shots_drawn_from_shared_rows_are_those_of_plain_rows():
    n = 6
    model = _model(n)
    X = RNG.normal(size=(4, n))
    plan = density_gradient_plan(model, X, method="commuting", shots=40)
    plain = [LazyCircuitJob(j._build, j.num_qubits, j._num_parameters, j.values, j.shots,
                            j.label, j.program) for j in plan.jobs]
    assert not any(isinstance(j.held_rows, SharedRows) for j in plain)
    for hamming in ("auto", "never"):
        shared = SamplerEngine(seed=4, progress=False, hamming_weight=hamming).run(plan.jobs)
        own = SamplerEngine(seed=4, progress=False, hamming_weight=hamming).run(plain)
        for a, b in zip(shared, own, strict=True):
            np.testing.assert_array_equal(a.bits, b.bits)
