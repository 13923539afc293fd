"""mixing-lemma at a tiny size, and oracles: the bound as a theorem over seeds, the terms
against a hand computation on 2 qubits."""


import numpy as np
import pytest
from qiskit import QuantumCircuit

from qdensity.analysis.mixing import mixing_lemma_terms
from qdensity.circuits.ansatze import round_robin
from qdensity.circuits.gates import RBSGate
from qdensity_paper import run
from qdensity_paper._lcu_training import orthogonal_matrix
from qdensity_paper.mixing_lemma import lemma_quantities, z0_values

TINY = {"num_qubits": 3, "num_subunitaries": 2, "train_size": 24, "test_size": 12,
        "student_epochs": 2, "alpha_epochs": 2, "batch_size": 8}


@pytest.fixture(scope="module")
def result(tmp_path_factory, checked_run):
    out = tmp_path_factory.mktemp("mix")
    return checked_run("mixing-lemma", TINY, [1, 4], out), out


def test_invariants(result):
    res, out = result
    for m in res.per_seed:
        assert m["lemma/bound_holds"] == 1.0
        assert m["lemma/distance_max"] <= m["lemma/bound"] + 1e-9
        assert m["lemma/bound"] == pytest.approx(m["lemma/eps_1"] ** 2 + 2 * m["lemma/eps_2"])
        assert m["lemma/holder_slack"] >= -1e-9
        assert m["lemma1/lemma1_bound"] == pytest.approx(
            m["lemma1/delta_1"] ** 2 / 4 + 2 * m["lemma1/delta_2"])
    assert len(res.curves["students/eps_1_vs_epoch"]["x"]) == 3
    assert res.curves["alpha/bound_vs_epoch"]["x"] == [0.0, 1.0, 2.0]


def test_bad_setting_names_it():
    with pytest.raises(ValueError, match="num_subunitaries"):
        run("mixing-lemma", config={**TINY, "num_subunitaries": 1}, seeds=1, progress=False)


@pytest.mark.parametrize("seed", range(12))
def test_measured_distance_never_exceeds_the_bound(seed):
    # the Hastings-Campbell lemma is a theorem: for any sub-unitaries, alpha and inputs
    rng = np.random.default_rng(seed)
    n, K = 4, 3
    circ = round_robin(n)
    base = rng.uniform(-np.pi, np.pi, circ.num_parameters)
    V = orthogonal_matrix(circ, base)
    spread = [0.05, 0.3, 1.0][seed % 3]
    mats = [orthogonal_matrix(circ, base + rng.normal(0, spread, base.size)) for _ in range(K)]
    alpha = rng.dirichlet(np.ones(K))
    X = rng.normal(size=(30, n))
    X /= np.linalg.norm(X, axis=1, keepdims=True)
    q = lemma_quantities(mats, alpha, V, X)
    assert q["distance_max"] <= q["bound"] + 1e-12
    assert q["holder_slack"] >= -1e-12  # |h - f| <= ||O|| x trace distance, pointwise


def _rbs(theta):
    qc = QuantumCircuit(2)
    qc.append(RBSGate(theta), [0, 1])
    return qc


def test_two_qubit_terms_by_hand():
    # unary subspace of 2 qubits: RBS(t) is the rotation [[c, -s], [s, c]]; V = identity
    t = np.array([0.3, -0.5])
    alpha = np.array([0.25, 0.75])
    mats = [orthogonal_matrix(_rbs(tk), []) for tk in t]
    for m, tk in zip(mats, t, strict=True):
        assert np.allclose(m, [[np.cos(tk), -np.sin(tk)], [np.sin(tk), np.cos(tk)]])
    c, s = np.cos(t), np.sin(t)
    cbar, sbar = alpha @ c, alpha @ s
    eps1 = max(2 * abs(np.sin(t / 2)))
    eps2 = np.hypot(cbar - 1, sbar)  # A - I is a scaled rotation
    terms = mixing_lemma_terms(mats, alpha, np.eye(2))
    assert terms["eps_1"] == pytest.approx(eps1)
    assert terms["eps_2"] == pytest.approx(eps2)
    assert terms["bound"] == pytest.approx(eps1**2 + 2 * eps2)
    # x = e_0: Lambda(rho) - rho = [[-S2, C], [C, S2]], trace norm 2 sqrt(S2^2 + C^2)
    S2, C = alpha @ s**2, alpha @ (c * s)
    q = lemma_quantities(mats, alpha, np.eye(2), np.array([[1.0, 0.0]]))
    assert q["distance_max"] == pytest.approx(2 * np.hypot(S2, C))
    # h = Tr(Z_0 e0 e0) = -1; f_k = 1 - 2 c_k^2; f_LCU = sbar^2 - cbar^2 (unnormalised)
    assert q["delta_1"] == pytest.approx(max(2 * s**2))
    assert q["delta_2"] == pytest.approx(abs(-1 - sbar**2 + cbar**2))
    assert q["density_error"] == pytest.approx(2 * S2)
    assert q["success_probability"] == pytest.approx(cbar**2 + sbar**2)
    assert q["lemma1_bound"] == pytest.approx(max(2 * s**2) ** 2 / 4
                                              + 2 * abs(-1 - sbar**2 + cbar**2))


def test_z0_values_by_hand():
    assert z0_values(np.array([1.0, 0.0, 0.0])) == pytest.approx(-1.0)
    assert z0_values(np.array([0.0, 0.6, 0.8])) == pytest.approx(1.0)
    assert z0_values(np.array([0.5, 0.5, 0.0])) == pytest.approx(0.0)
