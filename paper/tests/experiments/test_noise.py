"""The ``noise`` experiment (issue 13, issue 14 item 5): pure vs density on a noisy device,
raw, post-selected and mitigated; and its building block, the device estimate of a unary
model's outputs, against exact values and binomial bounds."""

import json

import numpy as np
import pytest

from qdensity.circuits.ansatze import round_robin
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.execution.samplers import target_sampler
from qdensity.hardware.targets import get_target
from qdensity.models.decompositions import by_moments
from qdensity.models.density import DensityQNN, Encoding
from qdensity.models.mixtures import SoftmaxMixture
from qdensity_paper import noise, run
from qdensity_paper._noise_device import allocate_shots, device_outputs

TINY = {"num_qubits": 3, "classes": 3, "train_size": 40, "test_size": 6, "shots": 4,
        "budget": 240, "batch_size": 2, "checkpoints": 2, "eval_shots": 12,
        "eval_shots_sweep": [6, 48], "calibration_shots": 100, "ceiling_epochs": 1}


# ------------------------------------------------------------------ allocate_shots
def test_allocate_shots_exact_values():
    assert allocate_shots([1.0], 7).tolist() == [7]
    assert allocate_shots([0.5, 0.25, 0.25], 11).tolist() == [5, 3, 3]  # 1 + 8 * alpha
    assert allocate_shots([0.2, 0.8], 2).tolist() == [1, 1]
    # 1 + 10 * (0.33.., 0.33.., 0.33..): 3.33 each, one leftover shot to the first
    assert allocate_shots(np.full(3, 1 / 3), 13).tolist() == [5, 4, 4]
    for alpha in np.random.default_rng(0).dirichlet(np.ones(5), size=20):
        out = allocate_shots(alpha, 101)
        assert out.sum() == 101 and out.min() >= 1
        assert np.all(np.abs(out - 1 - 96 * alpha) < 1.0)


def test_allocate_shots_refuses_bad_input():
    with pytest.raises(ValueError, match="K = 3"):
        allocate_shots(np.full(3, 1 / 3), 2)
    with pytest.raises(ValueError, match="probability vector"):
        allocate_shots([0.5, 0.6], 10)


# ------------------------------------------------------------------ device_outputs
def _density_model(n=4, seed=3):
    dec = by_moments(round_robin(n))
    model = DensityQNN(dec.sub_unitaries, SoftmaxMixture(logits=[0.3, -0.2, 0.5]),
                       encoding=Encoding.unary(n), readout="unary_probabilities")
    model.set_params(theta=np.random.default_rng(seed).uniform(-np.pi, np.pi,
                                                                model.num_parameters))
    return model


def test_device_outputs_noiseless_within_binomial_bounds():
    model = _density_model()
    X = np.random.default_rng(1).normal(size=(5, 4))
    target = get_target("line", 4, seed=2, noise=False)
    engine = SamplerEngine(target=target, seed=5, progress=False, mitigation="m3",
                           calibration_shots=200)
    total = 6000
    dev = device_outputs(model, X, engine=engine, shots=total)
    alpha = model.alpha(X)[0]
    exact_k = model.expert_outputs(X)  # (B, K, n)
    exact = np.einsum("k,bkn->bn", alpha, exact_k)
    assert np.allclose(exact, model.predict(X))
    per_k = allocate_shots(alpha, total)
    assert dev.shots.tolist() == per_k.tolist()
    # stratified estimator: variance sum_k alpha_k^2 p_k (1 - p_k) / S_k
    sigma = np.sqrt(np.einsum("k,bkn->bn", alpha**2 / per_k, exact_k * (1 - exact_k)))
    assert np.all(np.abs(dev.values["raw"] - exact) <= 5 * sigma + 1e-12)
    # no noise: nothing leaks out of the unary subspace, post-selection changes nothing,
    # readout calibration finds the identity
    assert np.allclose(dev.kept["raw"], 1.0)
    assert np.allclose(dev.values["ps"], dev.values["raw"])
    assert np.allclose(dev.values["m3"], dev.values["raw"], atol=1e-9)
    assert np.allclose(dev.values["m3_ps"], dev.values["raw"], atol=1e-9)
    assert np.allclose(dev.overhead, 1.0, atol=1e-9)
    labels = engine.ledger.by_label()
    assert labels["eval_k0"] == (5, 5 * per_k[0])
    assert sum(labels[f"eval_k{k}"][1] for k in range(3)) == 5 * total


def test_device_outputs_on_a_noisy_snapshot_postselection_helps():
    pytest.importorskip("qiskit_ibm_runtime")
    model = _density_model()
    X = np.random.default_rng(4).normal(size=(8, 4))
    target = get_target("fake_manila", seed=0)
    engine = SamplerEngine(target_sampler(target, seed=3, method="density_matrix"), target=target,
                           seed=3, progress=False)
    dev = device_outputs(model, X, engine=engine, shots=20_000)
    exact = model.predict(X)
    assert set(dev.values) == {"raw", "ps"}
    kept = dev.kept["raw"]
    assert np.all((kept > 0.5) & (kept < 1.0))  # noise leaks weight, most stays
    assert np.allclose(dev.values["raw"].sum(axis=1), kept)
    assert np.allclose(dev.values["ps"].sum(axis=1), 1.0)
    err_raw = np.abs(dev.values["raw"] - exact).sum(axis=1)
    err_ps = np.abs(dev.values["ps"] - exact).sum(axis=1)
    # 20k shots: sampling error ~0.02 in L1, far below the leak of 1 - kept
    assert err_ps.mean() < err_raw.mean()
    assert np.all(err_raw >= 1 - kept - 1e-12)  # the raw outputs lack the leaked weight


def test_device_outputs_refuses_non_unary_readout():
    model = DensityQNN([round_robin(3)], encoding=Encoding.unary(3), readout="observable")
    engine = SamplerEngine(seed=0, progress=False)
    with pytest.raises(ValueError, match="unary_probabilities"):
        device_outputs(model, np.ones((1, 3)), engine=engine, shots=10)


# ------------------------------------------------------------------ the experiment
def test_noise_experiment_small(tmp_path):
    pytest.importorskip("qiskit_ibm_runtime")
    pytest.importorskip("mthree")
    result = run("noise", config=TINY, seeds=[0, 3], out=tmp_path, progress=False)
    assert result.seeds == [0, 3] and len(result.per_seed) == 2
    for key, stats in result.summary.items():
        assert stats["low"] - 1e-9 <= stats["mean"] <= stats["high"] + 1e-9, key
    for seed_metrics in result.per_seed:
        for model in ("pure", "density"):
            # equal budgets, never exceeded; what is left is less than one step
            assert 0 < seed_metrics[f"{model}/train_shots"] <= TINY["budget"]
            for score in noise.SCORES:
                assert 0.0 <= seed_metrics[f"{model}/{score}_accuracy"] <= 1.0
            for v in ("raw", "m3"):
                assert 0.0 < seed_metrics[f"{model}/{v}_kept_fraction"] <= 1.0 + 1e-6
            assert seed_metrics[f"{model}/mitigation_overhead"] >= 1.0 - 1e-9
        # one density step (2 rows x 6 circuits x 4 shots = 48) is cheaper than a pure one
        assert seed_metrics["density/steps"] > seed_metrics["pure/steps"]
        assert seed_metrics["mitigation/calibration_shots"] > 0
        assert (seed_metrics["pure/two_qubit_gates_mean"]
                > seed_metrics["density/two_qubit_gates_mean"])
    for model in ("pure", "density"):
        for score in noise.SCORES:
            c = result.curves[f"{model}/{score}_vs_shots"]
            assert c["x"][0] == 0 and np.all(np.diff(c["x"]) > 0)
            assert 2 <= len(c["x"]) <= TINY["checkpoints"] + 1
            assert c["x"][-1] <= TINY["budget"]
            e = result.curves[f"{model}/{score}_vs_eval_shots"]
            assert e["x"] == [6.0, 48.0]
            assert all(lo - 1e-9 <= m <= hi + 1e-9
                       for lo, m, hi in zip(e["low"], e["mean"], e["high"], strict=True))
        assert len(set(result.curves[f"{model}/exact_vs_eval_shots"]["mean"])) == 1
        for v in ("raw", "ps", "m3", "m3_ps"):
            err = result.curves[f"{model}/{v}_error_vs_eval_shots"]
            assert len(err["x"]) == 2 and all(0 <= y <= 2 + 1e-9 for y in err["mean"])
    saved = json.loads((tmp_path / "noise-quick.json").read_text())
    assert saved["seeds"] == [0, 3]
    assert len(result.figures) == 4
    for path in result.figures:
        assert (tmp_path / path.split("/")[-1]).stat().st_size > 0


def test_noise_heavy_hex_without_mitigation():
    config = dict(noise.QUICK, **TINY)
    config.update(target="heavy_hex", mitigation=False, ceiling_epochs=0, eval_shots_sweep=[12])
    out = noise.run_seed(config, 1, False)
    assert out["device_qubits"] == 19
    assert "pure/m3_accuracy" not in out and "density/m3_ps_vs_shots" not in out["curves"]
    assert "density/ps_accuracy" in out and "pure/ceiling_accuracy" not in out
    assert out["mitigation/calibration_shots"] == 0
    assert _same(out, noise.run_seed(config, 1, False))  # bit for bit from the seed


def _same(a, b) -> bool:
    return json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)


@pytest.mark.parametrize("key, value, match", [
    ("num_qubits", 7, "num_qubits"), ("num_qubits", 2, "num_qubits"),
    ("classes", 11, "classes"), ("budget", 0, "budget"), ("mitigation", "yes", "mitigation"),
    ("eval_shots", 2, "eval_shots"), ("eval_shots_sweep", [], "eval_shots_sweep"),
    ("eval_shots_sweep", [64, 1], "eval_shots_sweep"), ("learning_rate", 0, "learning_rate"),
    ("target", "ideal", "target"), ("test_size", 10_000, "test_size"),
])
def test_bad_settings_name_the_setting(key, value, match):
    config = dict(noise.QUICK, **{key: value})
    with pytest.raises(ValueError, match=match):
        noise.run_seed(config, 0, False)


def test_missing_extras_say_what_to_install(monkeypatch):
    monkeypatch.setattr(noise, "snapshots_available", lambda: False)
    with pytest.raises(ImportError, match=r"pip install 'qdensity\[ibm\]'"):
        noise.check_config(dict(noise.QUICK))
    noise.check_config(dict(noise.QUICK, target="heavy_hex"))  # core targets need no extra
    with pytest.raises(ImportError, match=r"--set target=heavy_hex"):
        noise.check_config(dict(noise.QUICK))
    monkeypatch.setattr(noise, "_have_mthree", lambda: False)
    # the default needs neither extra: mitigation 'auto' is off without mthree (and recorded)
    assert noise.check_config(dict(noise.QUICK, target="heavy_hex"))["mitigation"] is False
    with pytest.raises(ImportError, match=r"mthree.*pip install 'qdensity\[ibm\]'"):
        noise.check_config(dict(noise.QUICK, target="heavy_hex", mitigation=True))
    noise.check_config(dict(noise.QUICK, target="heavy_hex", mitigation=False))
