"""The linearisation behind a mitigated row's standard error against mthree itself.

Oracles: mthree's own reduced matrix (``M3Mitigation.reduced_cal_matrix``: observed outcomes,
correction distance, columns renormalised), and central finite differences of mthree's own
corrected estimate when one calibrated error rate moves (its ``single_qubit_cals``) or when
shots move between two outcomes. A device whose qubits have different readout errors, so that
a qubit-order slip shows; six measured qubits, so that the distance (3) cuts pairs.
"""

import numpy as np
import pytest
from qiskit import QuantumCircuit
from qiskit.providers.fake_provider import GenericBackendV2
from qiskit_aer import AerSimulator
from qiskit_aer.noise import NoiseModel, ReadoutError

from qdensity.execution.sampler._correction import ReadoutCorrection
from qdensity.hardware.aer_sampling import HAMMING_WEIGHT_KEY
from qdensity.hardware.targets import get_target

M = 6
FLIPS = [(0.02, 0.10), (0.05, 0.04), (0.01, 0.15), (0.08, 0.06), (0.03, 0.12), (0.06, 0.02)]


def _setup(postselect):
    noise = NoiseModel()
    for q, (e0, e1) in enumerate(FLIPS):
        noise.add_readout_error(ReadoutError([[1 - e0, e0], [e1, 1 - e1]]), [q])
    tgt = get_target(GenericBackendV2(M, seed=3).target, noise_model=noise)
    qc = QuantumCircuit(M, M)
    qc.x(1)
    qc.ry(0.4, 0)
    qc.cx(0, 1)
    qc.ry(0.3, 4)
    qc.measure(range(M), range(M))
    qc.metadata = {HAMMING_WEIGHT_KEY: 1} if postselect else {}
    mem = AerSimulator(noise_model=noise).run(qc, shots=3000, memory=True,
                                              seed_simulator=11).result().get_memory()
    bits = np.array([[c == "1" for c in s[::-1]] for s in mem])[None]
    corr = ReadoutCorrection("m3", "hamming_weight" if postselect else None, tgt, 400, 5)
    w, _, lins = corr.weights(bits, qc, None)
    lin = lins[0]
    keys = ["".join("1" if b else "0" for b in u[::-1]) for u in lin.outcomes]
    counts = np.rint(lin.p * lin.shots)
    per_shot = _f(bits[0])
    return {"lin": lin, "mit": corr.mitigator(None), "keys": keys, "counts": counts,
            "per_shot": per_shot, "mean": float(np.mean(w[0] * per_shot)),
            "f_out": per_shot[lin.first]}


def _f(bits):
    z = 1.0 - 2.0 * bits
    return z[:, 0] + 0.5 * z[:, 0] * z[:, 1] - 0.25 * z[:, 5]


def _estimate(mit, counts: dict, keys, f_out, postselect) -> float:
    """mthree's corrected estimate of ``f`` from ``counts`` (``keys`` order, ``f_out`` per key)."""
    q = mit._m3.apply_correction(counts, list(range(M)))
    q = np.array([q.get(k, 0.0) for k in keys])
    keep = np.array([k.count("1") == 1 for k in keys]) if postselect else np.ones(len(keys),
                                                                                   bool)
    return float((q * f_out * keep).sum() / (q * keep).sum())


def _as_dict(case, counts=None) -> dict:
    counts = case["counts"] if counts is None else counts
    return dict(zip(case["keys"], counts.astype(int).tolist(), strict=True))


def test_reduced_matrix_is_mthrees():
    case = _setup(False)
    lin, keys = case["lin"], case["keys"]
    W, ordered = case["mit"]._m3.reduced_cal_matrix(_as_dict(case), list(range(M)), distance=3)
    order = [keys.index(k) for k in ordered]
    A, c = lin._matrix()
    ours = (A / c)[np.ix_(order, order)]
    assert lin.distance == 3 and (A == 0).any()  # the distance cuts some pairs
    np.testing.assert_allclose(ours, W, atol=2e-6)


@pytest.mark.parametrize("postselect", [False, True])
def test_calibration_gradient_matches_finite_differences_of_mthree(postselect):
    case = _setup(postselect)
    lin, mit, keys, mean, f_out = (case[k] for k in ("lin", "mit", "keys", "mean", "f_out"))
    counts = _as_dict(case)
    assert _estimate(mit, counts, keys, f_out, postselect) == pytest.approx(mean, abs=1e-6)
    grads = lin.calibration_gradient(case["per_shot"], mean)
    assert len(grads) == 2 * M
    h = 2e-3
    cals = mit._m3.single_qubit_cals
    for (qubit, s), (dv, e, _) in grads.items():
        saved = cals[qubit].copy()
        moved = []
        for step in (h, -h):
            a = saved.astype(float)
            a[1 - s, s], a[s, s] = e + step, 1 - e - step
            cals[qubit] = a.astype(saved.dtype)
            moved.append(_estimate(mit, counts, keys, f_out, postselect))
        cals[qubit] = saved
        fd = (moved[0] - moved[1]) / (2 * h)
        assert float(dv) == pytest.approx(fd, rel=5e-3, abs=2e-4), (qubit, s)


def test_shot_gradient_matches_finite_differences_of_mthree():
    # g = W^-T r is dV/dp: moving shots between outcomes i and k moves V by (g_i - g_k) d / N
    case = _setup(False)
    lin, mit, keys, counts, f_out = (case[k] for k in ("lin", "mit", "keys", "counts", "f_out"))
    g = lin._g(case["per_shot"], case["mean"], *lin._matrix())
    d = 2.0
    for i, k in [(0, 1), (0, len(keys) - 1), (2, 3)]:
        moved = []
        for step in (d, -d):
            c = counts.copy()
            c[i] += step
            c[k] -= step
            moved.append(_estimate(mit, dict(zip(keys, c.tolist(), strict=True)), keys, f_out,
                                   False))
        fd = (moved[0] - moved[1]) / (2 * d) * lin.shots
        assert g[i] - g[k] == pytest.approx(fd, rel=5e-3, abs=2e-4), (i, k)
