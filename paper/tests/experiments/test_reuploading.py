"""The ``reuploading`` experiment (Fig. 6, Supp. J) at a tiny size, and the exact single-qubit
re-uploading model against Qiskit statevectors and finite differences."""

from __future__ import annotations

import json

import numpy as np
import pytest
from qiskit import QuantumCircuit
from qiskit.quantum_info import SparsePauliOp, Statevector

from qdensity.circuits.ansatze import reuploading
from qdensity.models.single_qubit import SingleQubitReuploading
from qdensity_paper import run
from qdensity_paper.reuploading import density_depth

TINY = {"layers": [2, 4], "experts": 2, "experts_at_max": [3], "epochs": 3, "num_train": 10,
        "num_test": 12, "curve_points": 3}


def _qiskit_expert(theta_k, x, encoding):
    """<Z> of one sub-unitary from a circuit built gate by gate (independent of the model)."""
    if encoding == "rx":
        qc = reuploading(len(theta_k))
        th = sorted((p for p in qc.parameters if p.name.startswith("θ")), key=lambda p: p.index)
        xp = next(p for p in qc.parameters if p.name.startswith("x"))
        bind = {xp: x, **dict(zip(th, np.ravel(theta_k), strict=True))}
        qc = qc.assign_parameters(bind)
    else:
        qc = QuantumCircuit(1)
        for t1, t2, t3 in theta_k:  # Supp. J: R_y(x) R_x(x) then R_z R_y R_z
            qc.rx(x, 0)
            qc.ry(x, 0)
            qc.rz(t3, 0)
            qc.ry(t2, 0)
            qc.rz(t1, 0)
    return Statevector(qc).expectation_value(SparsePauliOp("Z")).real


@pytest.mark.parametrize("encoding", ["rx", "rx_ry"])
def test_single_qubit_model_matches_qiskit_statevectors(encoding):
    model = SingleQubitReuploading(3, 2, encoding=encoding, seed=4)
    model.logits = np.array([0.4, -0.3])
    xs = np.array([-0.9, -0.1, 0.35, 1.0])
    expected = np.array([[_qiskit_expert(model.theta[k], x, encoding) for k in range(2)]
                         for x in xs])
    assert np.allclose(model.expert_outputs(xs[:, None]), expected, atol=1e-12)
    alpha = np.exp(model.logits) / np.exp(model.logits).sum()
    assert np.allclose(model.predict(xs), expected @ alpha, atol=1e-12)


@pytest.mark.parametrize("encoding, k", [("rx", 1), ("rx", 3), ("rx_ry", 2)])
def test_single_qubit_gradient_matches_finite_differences(encoding, k):
    model = SingleQubitReuploading(2, k, encoding=encoding, seed=7)
    if k > 1:
        model.logits = np.linspace(-0.5, 0.5, k)
    rng = np.random.default_rng(1)
    x, y = rng.uniform(-1, 1, 6), rng.normal(size=6)
    loss, grad = model.loss_and_grad(x, y)
    assert loss == pytest.approx(model.mse(x, y))
    p = model.get_params()
    assert grad.shape == p.shape == (model.num_parameters,)
    fd = np.zeros_like(p)
    for i in range(p.size):
        e = np.zeros_like(p)
        e[i] = 1e-6
        model.set_params(p + e)
        up = model.mse(x, y)
        model.set_params(p - e)
        fd[i] = (up - model.mse(x, y)) / 2e-6
    model.set_params(p)
    assert np.allclose(grad, fd, atol=1e-7)


def test_single_qubit_model_refuses_bad_input():
    with pytest.raises(ValueError, match="encoding"):
        SingleQubitReuploading(2, encoding="rz")
    with pytest.raises(ValueError, match="num_layers"):
        SingleQubitReuploading(0)
    with pytest.raises(ValueError, match="y must have shape"):
        SingleQubitReuploading(1).loss_and_grad(np.zeros(3), np.zeros(2))


def test_density_depth_keeps_the_parameter_budget():
    assert [density_depth(L, 5) for L in (5, 10, 50)] == [1, 2, 10]
    assert density_depth(50, 7) == 7 and density_depth(50, 2) == 25 and density_depth(3, 5) == 1


def test_tiny_run_shape_and_invariants(tmp_path):
    res = run("reuploading", seeds=[0, 5], config=TINY, out=tmp_path, progress=False)
    assert res.seeds == [0, 5]
    for row in res.per_seed:
        for L in (2, 4):
            for tag, params in (("vanilla", 3 * L), ("density", 3 * 2 * density_depth(L, 2))):
                p = f"methods/{tag}/L{L}"
                assert row[f"{p}/gap"] == pytest.approx(row[f"{p}/test_mse"] -
                                                        row[f"{p}/train_mse"])
                assert row[f"{p}/parameters"] == params
        c = row["curves"]
        assert c["methods/vanilla/test_mse_vs_L"]["x"] == [2.0, 4.0]
        assert c["methods/test_mse_vs_K"]["x"] == [1.0, 2.0, 3.0]
        shots = c["methods/density/L4/test_vs_shots"]["x"]
        assert len(shots) == 3 and np.all(np.diff(shots) > 0)
        # parameter shift: 2 circuits per angle + 1 forward per sub-unitary, 10 rows, 1000 shots
        assert row["methods/vanilla/L4/shots"] == (6 * 4 + 1) * 10 * 1000 * 3
        assert row["methods/density/L4/shots"] == 2 * (6 * 2 + 1) * 10 * 1000 * 3
        assert len(c["methods/truth/fit"]["y"]) == 12
    for key, s in res.summary.items():
        assert s["low"] <= s["mean"] <= s["high"], key
    doc = json.loads((tmp_path / "reuploading-quick.json").read_text())
    assert doc["seeds"] == [0, 5]
    assert len(res.figures) == 2
    assert all((tmp_path / p.rsplit("/", 1)[-1]).stat().st_size > 0 for p in res.figures)


def test_both_settings_and_reproducibility():
    cfg = dict(TINY, setting="both", layers=[2], experts_at_max=[], epochs=1)
    a = run("reuploading", seeds=[2], config=cfg, progress=False).per_seed[0]
    b = run("reuploading", seeds=[2], config=cfg, progress=False).per_seed[0]
    assert "methods/vanilla/L2/test_mse" in a and "supp_j/density/L2/test_mse" in a
    assert a["curves"] == b["curves"] and a["supp_j/vanilla/L2/test_mse"] == \
        b["supp_j/vanilla/L2/test_mse"]


@pytest.mark.parametrize("override, match", [
    ({"setting": "pennylane"}, "setting"),
    ({"layers": [0, 3]}, "layers"),
    ({"experts": 1}, "experts"),
    ({"learning_rate": -1.0}, "learning_rate"),
    ({"experts_at_max": [1]}, "experts_at_max"),
])
def test_bad_settings_are_refused(override, match):
    with pytest.raises(ValueError, match=match):
        run("reuploading", seeds=[0], config=dict(TINY, **override), progress=False)


def test_t3_runs_on_its_own_on_supp_j_data():
    """setting='t3' (Supp. J, Fig. 18) fits T_3 = 4x^3 - 3x with Supp. J's noise; 'both' stays
    the two readings of Fig. 6b."""
    from qdensity.datasets.chebyshev import chebyshev_split
    from qdensity_paper.reuploading import BOTH, SETTINGS

    degree, noise, encoding = SETTINGS["t3"]
    _, X_te, _, y_te = chebyshev_split(degree, noise, num_train=10, num_test=12, seed=0)
    x = np.ravel(X_te)
    assert np.allclose(np.ravel(y_te), 4 * x**3 - 3 * x)
    assert (noise, encoding) == SETTINGS["supp_j"][1:] and "t3" not in BOTH
    cfg = dict(TINY, setting="t3", layers=[2], experts_at_max=[], epochs=1)
    row = run("reuploading", seeds=[1], config=cfg, progress=False).per_seed[0]
    assert "t3/vanilla/L2/test_mse" in row and "t3/density/L2/gap" in row
    assert not any(k.startswith(("methods/", "supp_j/")) for k in row)
