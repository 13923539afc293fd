"""orthoqnn-depth at a size far below quick: shapes, invariants, shot accounting, settings."""


import numpy as np
import pytest

from qdensity_paper import run

N = 4  # round-robin on 4 qubits: 6 RBS gates in 3 layers
TINY = {"num_qubits": N, "depths": [1, 3], "pretrain_epochs": 2, "epochs": 1,
        "train_size": 40, "test_size": 20, "batch_size": 20, "shots_per_circuit": 10}


@pytest.fixture(scope="module")
def tiny(tmp_path_factory, checked_run):
    out = tmp_path_factory.mktemp("orthoqnn")
    return checked_run("orthoqnn-depth", TINY, [0, 3], out), out


def test_seeds_files_and_cis(tiny):
    result, out = tiny
    assert {p.rsplit("/", 1)[-1] for p in result.figures} == {
        "orthoqnn-depth-quick-shallow.png", "orthoqnn-depth-quick-depths.png"}
    for name in ("pure", "D1", "D3"):
        acc = result.summary[f"{name}/test_accuracy"]["mean"]
        assert 0.0 <= acc <= 1.0


def test_circuit_counts_match_the_gradient_rules(tiny):
    result, _ = tiny
    gates = N * (N - 1) // 2
    seed = result.per_seed[0]
    # pure: four-term shift rule per RBS angle plus one forward circuit
    assert seed["pure/circuits_per_row"] == 4 * gates + 1
    # D = 1: each of the n - 1 sub-unitaries is one commuting block: 1 gradient + 1 forward
    assert seed["D1/circuits_per_row"] == 2 * (N - 1)
    assert seed["D1/pretrain_circuits_per_row"] == 2 * (N - 1)
    # D = n - 1: n - 1 full round-robin circuits, each by parameter shift
    assert seed["D3/circuits_per_row"] == (N - 1) * (4 * gates + 1)
    assert seed["D1/num_parameters"] == (N - 1) * (N // 2)
    assert seed["D3/num_parameters"] == (N - 1) * gates


def test_curves_lengths_and_shots(tiny):
    result, _ = tiny
    e1, e2 = TINY["pretrain_epochs"], TINY["epochs"]
    for seed in result.per_seed:
        rows, shots = seed["train_rows"], TINY["shots_per_circuit"]
        assert rows == TINY["train_size"] and seed["test_rows"] == TINY["test_size"]
        curves = seed["curves"]
        pure = curves["pure/test_vs_shots"]["x"]
        assert len(pure) == e1 + e2
        assert pure == [seed["pure/circuits_per_row"] * rows * shots * e
                        for e in range(1, e1 + e2 + 1)]
        for d in (1, 3):
            c = curves[f"D{d}/test_vs_shots"]
            assert len(c["x"]) == len(c["y"]) == e1 + e2
            assert np.all(np.diff(c["x"]) > 0)
            per_epoch = seed[f"D{d}/circuits_per_row"] * rows * shots
            assert c["x"][-1] == seed[f"D{d}/shots"] == (e1 + e2) * per_epoch
            assert curves[f"D{d}/test_vs_epoch"]["x"] == list(range(1, e1 + e2 + 1))
    for name, c in result.curves.items():
        bands = zip(c["low"], c["mean"], c["high"], strict=True)
        assert all(lo <= m <= hi for lo, m, hi in bands), name


def test_reproducible():
    config = dict(TINY, depths=[1], pretrain_epochs=1)
    a = run("orthoqnn-depth", seeds=[5], config=config, progress=False).per_seed[0]
    b = run("orthoqnn-depth", seeds=[5], config=config, progress=False).per_seed[0]
    a.pop("seconds"), b.pop("seconds")
    assert a == b


def test_mnist_files(tmp_path):
    rng = np.random.default_rng(0)
    path = tmp_path / "mnist.npz"
    np.savez(path, x_train=rng.integers(0, 256, (50, 28, 28), dtype=np.uint8),
             y_train=np.arange(50) % 10, x_test=rng.integers(0, 256, (20, 28, 28), dtype=np.uint8),
             y_test=np.arange(20) % 10)
    config = dict(TINY, depths=[1], pretrain_epochs=1, dataset="mnist", mnist_dir=str(path),
                  train_size=None)
    seed = run("orthoqnn-depth", seeds=1, config=config, progress=False).per_seed[0]
    assert seed["train_rows"] == 50 and seed["test_rows"] == 20
    assert seed["data/source"] == f"MNIST files at {str(path)!r}"


@pytest.mark.parametrize("change, setting", [
    ({"depths": [0]}, "depths"), ({"depths": [4]}, "depths"), ({"depths": []}, "depths"),
    ({"depths": [1, 1]}, "depths"), ({"dataset": "cifar"}, "dataset"),
    ({"mixture": "gate"}, "mixture"), ({"learning_rate": -1.0}, "learning_rate"),
    ({"epochs": 0}, "epochs"), ({"num_qubits": 2}, "num_qubits"),
    ({"shots_per_circuit": 1.5}, "shots_per_circuit"),
])
def test_bad_settings(change, setting):
    with pytest.raises(ValueError, match=setting):
        run("orthoqnn-depth", seeds=1, config=dict(TINY, **change), progress=False)


def test_warm_start_point_is_the_mixture_before_any_step(monkeypatch):
    """The recorded warm start (``D{d}/warm_start_accuracy``, the one-point curves at the end
    of pretraining) is the density model before its first step: the K pretrained sub-models'
    unary probabilities from qiskit Statevectors, mixed with the MoE gate's uniform start
    (W = 0, b = 0: alpha = 1/K), through the mean of their read-outs, argmax."""
    from qiskit.quantum_info import Statevector

    from qdensity.models.decompositions import trainable_parameters
    from qdensity_paper import orthoqnn_depth as od

    fitted = []
    real_fit = od._fit
    monkeypatch.setattr(od, "_fit", lambda *a, **kw: (fitted.append(real_fit(*a, **kw)),
                                                       fitted[-1])[1])
    config = {**od.EXPERIMENT.quick, **TINY, "mixture": "moe", "part": "D1"}
    out = od.run_seed(config, 0, False)
    subs = fitted[:-1]  # the last fit is the density model's
    assert len(subs) == N - 1
    X_te, y_te = od.load_data(config, 0, N)[1::2]
    mix = np.zeros((len(X_te), N))
    for clf in subs:
        model = clf.model_
        sub = model.sub_unitaries[0]
        names = trainable_parameters(sub)
        theta = model.theta[[model.parameters.index(p) for p in names]]
        bound = sub.assign_parameters(dict(zip(names, theta, strict=True)))
        for b, x in enumerate(X_te):
            enc = model.encoding.circuit.assign_parameters(model.encoding.values(x[None])[0])
            probs = Statevector(enc.compose(bound)).probabilities()
            mix[b] += probs[[1 << j for j in range(N)]] / len(subs)
    W = np.mean([clf.post_.params["W"] for clf in subs], axis=0)
    bias = np.mean([clf.post_.params["b"] for clf in subs], axis=0)
    expected = np.mean(subs[0].classes_[np.argmax(mix @ W + bias, axis=1)] == y_te)
    assert out["D1/warm_start_accuracy"] == pytest.approx(expected, abs=1e-12)
    e1 = TINY["pretrain_epochs"]
    assert out["curves"]["D1/warm_start/test_vs_epoch"] == {
        "x": [e1], "y": [expected], "x_label": "epoch", "y_label": "test accuracy"}
    shots = out["curves"]["D1/warm_start/test_vs_shots"]["x"]
    assert shots == [out["curves"]["D1/test_vs_shots"]["x"][e1 - 1]]
