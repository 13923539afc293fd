"""From a fitted model to a sampled answer (issue "A library people can adopt", item 5).

Oracles: the exact outputs (``predict_proba`` / ``predict``, unary engine); the multinomial
covariance of exact unary probabilities pushed through the read-out's Jacobian written out by
hand (softmax of ``F W + b``); the readout channel of a device whose only noise is a known
readout error, applied to the exact unary probabilities (post-selection's oracle); the
binomial standard error written out; numpy's SVD for the PCA. Statistical checks use 5
standard errors (false-failure rate below 1e-6 per entry, a few dozen entries per test).
"""

from __future__ import annotations

import logging
import warnings

import numpy as np
import pytest
from _stats import stat_seed
from qiskit.providers.fake_provider import GenericBackendV2
from qiskit_aer.noise import NoiseModel, ReadoutError
from sklearn.datasets import load_breast_cancer
from sklearn.exceptions import NotFittedError
from sklearn.model_selection import train_test_split

from qdensity.circuits.ansatze.hamming import round_robin
from qdensity.execution.job_results import JobResult, unary_frequencies
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.hardware.targets import get_target
from qdensity.learning import QNNClassifier, QNNRegressor, UnscaledFeaturesWarning
from qdensity.models.decompositions import by_moments
from qdensity.models.density import DensityQNN
from qdensity.models.encoding import Encoding

Z5 = 5.0


@pytest.fixture(scope="module")
def cancer():
    X, y = load_breast_cancer(return_X_y=True)
    return X, y


@pytest.fixture(scope="module")
def small(cancer):
    X, y = cancer
    return QNNClassifier(num_qubits=4, epochs=2, verbose=False).fit(X, y)


def _softmax(z):
    e = np.exp(z - z.max(axis=1, keepdims=True))
    return e / e.sum(axis=1, keepdims=True)


def _by_hand(clf, F):
    """softmax(F W + b) and its Jacobian in F, written out (the post layer's parameters)."""
    W, b = clf.post_.params["W"], clf.post_.params["b"]
    P = _softmax(F @ W + b)
    C = P.shape[1]
    dP = P[:, :, None] * (np.eye(C)[None] - P[:, None, :])
    return P, np.einsum("bcd,md->bcm", dP, W)


# ---------------------------------------------------------------- estimate: values and errors
def test_estimate_is_shaped_like_predict_proba_and_agrees_within_its_errors(small, cancer):
    X = cancer[0][:6]
    est = small.estimate(X, shots=3000, seed=stat_seed(3))
    exact = small.predict_proba(X)
    assert est.value.shape == exact.shape == est.standard_error.shape == (6, 2)
    assert np.all(est.standard_error > 0)
    assert np.all(np.abs(est.value - exact) < Z5 * est.standard_error)
    np.testing.assert_allclose(est.value.sum(axis=1), 1.0, atol=1e-12)


def test_estimate_standard_error_is_the_multinomial_delta_method(cancer):
    X, y = cancer
    clf = QNNClassifier(num_qubits=4, decomposition="none", epochs=2, verbose=False).fit(X, y)
    shots = 4000
    est = clf.estimate(X[:5], shots=shots, seed=stat_seed(5))
    p = clf.model_.predict(clf.transform(X[:5]))  # exact unary probabilities (B, n)
    _, J = _by_hand(clf, p)
    cov = (np.einsum("bm,mn->bmn", p, np.eye(p.shape[1])) - p[:, :, None] * p[:, None, :])
    se_true = np.sqrt(np.einsum("bcm,bmn,bcn->bc", J, cov, J) / shots)
    np.testing.assert_allclose(est.standard_error, se_true, rtol=0.2)


def test_estimate_spread_over_seeds_matches_its_standard_error(small, cancer):
    x = cancer[0][:1]
    vals = np.array([small.estimate(x, shots=400, seed=stat_seed(100) + s).value[0, 1]
                     for s in range(24)])
    se = small.estimate(x, shots=400, seed=stat_seed(7)).standard_error[0, 1]
    # the sample sd of 24 draws lies within [0.5, 1.6] sd with probability > 0.999
    assert 0.5 * se < vals.std(ddof=1) < 1.6 * se


def test_regressor_estimate_is_shaped_like_predict():
    X = np.random.default_rng(0).normal(size=(40, 3))
    reg = QNNRegressor(epochs=2, verbose=False).fit(X, X[:, 0])
    est = reg.estimate(X[:4], shots=2000, seed=stat_seed(1))
    assert est.value.shape == est.standard_error.shape == (4,)
    assert np.all(np.abs(est.value - reg.predict(X[:4])) < Z5 * est.standard_error)
    obs = QNNRegressor(readout="observable", mixture="moe", epochs=2, verbose=False)
    obs.fit(X, X[:, 0])  # <Z_0> read out, a data-dependent mixture
    est = obs.estimate(X[:4], shots=2000, seed=stat_seed(6))
    assert est.value.shape == (4,)
    assert np.all(np.abs(est.value - obs.predict(X[:4])) < Z5 * est.standard_error)
    reg2 = QNNRegressor(epochs=1, verbose=False).fit(X, X[:, :2])
    est2 = reg2.estimate(X[:3], shots=500, seed=0)
    assert est2.value.shape == reg2.predict(X[:3]).shape == (3, 2)


def test_estimate_records_its_shots_on_the_engine_ledger(small, cancer):
    engine = SamplerEngine(seed=0, progress=False)
    small.estimate(cancer[0][:3], engine=engine, shots=100)
    K = small.model_.num_subunitaries
    assert engine.ledger.total_shots == K * 3 * 100


def _readout_only_target(p01=0.08, p10=0.03):
    noise = NoiseModel()
    noise.add_all_qubit_readout_error(ReadoutError([[1 - p10, p10], [p01, 1 - p01]]))
    return get_target(GenericBackendV2(4, seed=3).target, noise_model=noise), p01, p10


def test_postselected_estimate_against_the_readout_channel(small, cancer):
    target, p01, p10 = _readout_only_target()
    X = cancer[0][:3]
    engine = SamplerEngine(target=target, seed=stat_seed(2), progress=False,
                           postselect="hamming_weight")
    est = small.estimate(X, engine=engine, shots=4000)
    # oracle: exact unary probabilities through the readout channel, keep weight 1, renormalise
    n = small.num_qubits_
    p = small.model_.predict(small.transform(X))
    A = np.array([[1 - p10, p01], [p10, 1 - p01]])  # A[read, true]
    outs = np.arange(2**n)
    bits = (outs[:, None] >> np.arange(n)) & 1
    noisy = np.zeros((3, 2**n))
    for j in range(n):
        true = np.zeros(n, dtype=int)
        true[j] = 1
        noisy += p[:, j:j + 1] * np.prod(A[bits, true[None, :]], axis=1)[None, :]
    unary = noisy[:, 1 << np.arange(n)]
    F = unary / unary.sum(axis=1, keepdims=True)
    oracle, _ = _by_hand(small, F)
    assert np.all(np.abs(est.value - oracle) < Z5 * est.standard_error)


def test_mitigated_estimate_removes_the_readout_bias_within_its_errors(small, cancer):
    target, _, _ = _readout_only_target()
    X = cancer[0][:3]
    engine = SamplerEngine(target=target, seed=stat_seed(4), progress=False, mitigation="m3",
                           calibration_shots=4000)
    est = small.estimate(X, engine=engine, shots=4000)
    raw = small.estimate(X, engine=SamplerEngine(target=target, seed=stat_seed(4),
                                                 progress=False), shots=4000)
    exact = small.predict_proba(X)
    assert np.all(np.abs(est.value - exact) < Z5 * est.standard_error)
    assert np.all(est.standard_error > raw.standard_error)  # the correction's own spread


def test_estimate_refuses_bad_input(small, cancer):
    X = cancer[0][:2]
    with pytest.raises(ValueError, match="shots"):
        small.estimate(X, shots=1)
    with pytest.raises(TypeError, match="engine"):
        small.estimate(X, engine="exact", shots=10)
    with pytest.raises(ValueError, match="seed"):
        small.estimate(X, engine=SamplerEngine(seed=0, progress=False), shots=10, seed=1)
    with pytest.raises(ValueError, match="rows at a time"):
        small.estimate(cancer[0][:300], shots=10**6)  # refused before anything runs
    with pytest.raises(NotFittedError):
        QNNClassifier().estimate(X, shots=10)
    amp = QNNClassifier(num_qubits=3, readout="unary_amplitudes", epochs=1,
                        verbose=False).fit(*cancer)
    with pytest.raises(ValueError, match="unary_amplitudes"):
        amp.estimate(X, shots=10)


# ---------------------------------------------------------------- models: sample, plans
def _unary_model(seed=0):
    dec = by_moments(round_robin(4))
    K = len(dec.sub_unitaries)
    return DensityQNN(dec.sub_unitaries, np.full(K, 1.0 / K), encoding=Encoding.unary(4),
                      readout="unary_probabilities", seed=seed)


@pytest.mark.parametrize("mode", ["train", "eval"])
@pytest.mark.parametrize("scheduler", ["per_shot", "proportional"])
def test_unary_probability_model_samples_within_its_errors(mode, scheduler):
    model = _unary_model()
    getattr(model, mode)()
    x = np.array([1.0, 2.0, 3.0, 4.0])
    res = model.sample(x, 3000, scheduler=scheduler, seed=stat_seed(9))
    exact = model.predict(x[None])[0]
    assert res.estimate.shape == res.standard_error.shape == (4,)
    assert np.all(np.abs(res.estimate - exact) < Z5 * res.standard_error)
    assert res.shots_used == 3000


@pytest.mark.parametrize("options", [{"mitigation": "m3"}, {"postselect": "hamming_weight"}])
def test_unary_probability_sampling_corrects_a_readout_only_device(options):
    # weight-preserving circuits and readout errors only: M3 recovers the exact p_j;
    # post-selection the readout channel's weight-1 part, renormalised
    target, p01, p10 = _readout_only_target()
    model = _unary_model()
    x = np.array([1.0, 2.0, 3.0, 4.0])
    res = model.sample(x, 4000, target=target, seed=stat_seed(12), **options)
    exact = model.predict(x[None])[0]
    if "postselect" in options:  # the oracle: the readout channel, weight 1 kept, renormalised
        stay = (1 - p01) * (1 - p10) ** 3  # e_j read as e_j
        move = p01 * p10 * (1 - p10) ** 2  # e_i read as e_j: bit i lost, bit j gained
        q = exact * stay + (1 - exact) * move
        exact = q / q.sum()
    assert np.all(np.abs(res.estimate - exact) < Z5 * res.standard_error)


def test_sample_refuses_what_it_cannot_estimate():
    model = _unary_model()
    with pytest.raises(ValueError, match="neyman"):
        model.sample([1.0, 2.0, 3.0, 4.0], 100, scheduler="neyman")
    amp = DensityQNN(_unary_model().sub_unitaries, encoding=Encoding.unary(4),
                     readout="unary_amplitudes")
    with pytest.raises(ValueError, match="unary_probabilities"):
        amp.sample([1.0, 2.0, 3.0, 4.0], 100)


def test_expectation_plan_refuses_a_unary_readout():
    with pytest.raises(ValueError, match="probabilities_plan"):
        _unary_model().expectation_plan(0, [[1.0, 2.0, 3.0, 4.0]])


def test_unary_frequencies_standard_errors_are_binomial_and_wilson_floored():
    rng = np.random.default_rng(0)
    shots = 200
    outcomes = rng.choice([1, 2, 4, 3], size=(2, shots), p=[0.5, 0.3, 0.0, 0.2])
    bits = ((outcomes[..., None] >> np.arange(3)) & 1).astype(bool)
    res = JobResult(None, shots, None, bits=bits)
    assert len(unary_frequencies(res)) == 2  # the two-value form is unchanged
    p, kept, se = unary_frequencies(res, return_std=True)
    assert np.all(p[:, 2] == 0.0)
    by_hand = np.sqrt(p * (1 - p) / shots + 1.0 / (4 * shots**2))
    np.testing.assert_allclose(se, by_hand)
    assert np.all(se[:, 2] >= 1.0 / (2 * shots))  # never zero
    p_ps, _, se_ps = unary_frequencies(res, postselect=True, return_std=True)
    n_kept = kept[:, None] * shots
    np.testing.assert_allclose(se_ps, np.sqrt(p_ps * (1 - p_ps) / n_kept
                                              + 1.0 / (4 * n_kept**2)))
    # unit weights (a corrected run that corrected nothing): the same errors, through the
    # weighted path (post-selected: the ratio's per-shot influence)
    ones = JobResult(None, shots, None, bits=bits, weights=np.ones((2, shots)),
                     effective_shots=np.full(2, float(shots)))
    np.testing.assert_allclose(unary_frequencies(ones, return_std=True)[2], se)
    np.testing.assert_allclose(unary_frequencies(ones, postselect=True, return_std=True)[2],
                               se_ps)
    exact = JobResult(np.full((1, 8), 1 / 8), None, None)
    assert np.all(unary_frequencies(exact, return_std=True)[2] == 0.0)


# ---------------------------------------------------------------- encoding: transform, scaling
def test_transform_is_standardisation_then_pca_then_the_constant(cancer, caplog):
    X, y = cancer
    with caplog.at_level(logging.INFO, logger="qdensity.learning.estimators"):
        clf = QNNClassifier(num_qubits=6, constant=2.0, epochs=1, verbose=False).fit(X, y)
    assert "30 features -> standardised -> PCA to 5 + constant qubit (2) = 6 qubits" in \
        caplog.text
    Z = clf.transform(X[:7])
    assert Z.shape == (7, 6)
    np.testing.assert_array_equal(Z[:, 5], 2.0)
    S = (X - X.mean(axis=0)) / X.std(axis=0)
    _, _, Vt = np.linalg.svd(S - S.mean(axis=0), full_matrices=False)
    oracle = S[:7] @ Vt[:5].T
    np.testing.assert_allclose(np.abs(Z[:, :5]), np.abs(oracle), atol=1e-8)  # up to signs
    assert clf.num_qubits_ == 6 and clf.pca_.n_components_ == 5


def test_default_settings_beat_the_majority_rate_on_breast_cancer(cancer):
    X, y = cancer
    Xtr, Xte, ytr, yte = train_test_split(X, y, test_size=0.3, random_state=0, stratify=y)
    majority = max(np.mean(yte), 1 - np.mean(yte))
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnscaledFeaturesWarning)  # the default scales
        clf = QNNClassifier(verbose=False).fit(Xtr, ytr)
    assert clf.num_qubits_ == 31
    assert clf.score(Xte, yte) > majority + 0.1


def test_unscaled_features_warn(cancer):
    X, y = cancer
    with pytest.warns(UnscaledFeaturesWarning, match="standard deviations differ"):
        QNNClassifier(scale=False, num_qubits=4, epochs=1, verbose=False).fit(X, y)
    template = QNNClassifier(num_qubits=4, epochs=1, verbose=False).fit(X, y).model_
    with pytest.warns(UnscaledFeaturesWarning):
        QNNClassifier(template, epochs=1, verbose=False).fit(X[:, [0, 1, 3, 9]], y)
    with pytest.raises(TypeError, match="scale"):
        QNNClassifier(scale="yes").fit(X, y)


def test_saved_scaler_round_trips(tmp_path, small, cancer):
    X = cancer[0]
    path = tmp_path / "clf.json"
    small.save(path)
    back = QNNClassifier().load(path)
    np.testing.assert_allclose(back.predict_proba(X[:20]), small.predict_proba(X[:20]))
    np.testing.assert_allclose(back.transform(X[:5]), small.transform(X[:5]))
