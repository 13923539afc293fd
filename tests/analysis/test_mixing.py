"""The mixing lemma against a closed form (two opposite Z rotations: the density channel is a
dephasing channel with diamond distance 2 sin^2 e) and against channel distances computed from
dense matrices for random near-target unitaries, on the Choi state and random inputs."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from qdensity.analysis.mixing import mixing_lemma_terms, supervised_mixing_bound, trace_distance

RNG = np.random.default_rng(8)


def _near(V, scale):
    d = V.shape[0]
    H = RNG.normal(size=(d, d)) + 1j * RNG.normal(size=(d, d))
    return expm(-1j * scale * (H + H.conj().T) / 2) @ V


def _choi_distance(unitaries, alpha, V):
    """||(Lambda - V.V^dag) (x) id (|Omega><Omega|)||_1 on the maximally entangled state."""
    d = V.shape[0]
    omega = np.eye(d).reshape(-1) / np.sqrt(d)
    def apply(U):
        psi = np.kron(U, np.eye(d)) @ omega
        return np.outer(psi, psi.conj())
    lam = sum(a * apply(U) for a, U in zip(alpha, unitaries, strict=True))
    return trace_distance(lam, apply(V))


def test_closed_form_dephasing():
    for e in (0.05, 0.2, 0.5):
        U = [np.diag(np.exp([1j * e, -1j * e])), np.diag(np.exp([-1j * e, 1j * e]))]
        t = mixing_lemma_terms(U, [0.5, 0.5], np.eye(2))
        assert t["eps_1"] == pytest.approx(2 * np.sin(e / 2))
        assert t["eps_2"] == pytest.approx(1 - np.cos(e))
        assert t["bound"] == pytest.approx(8 * np.sin(e / 2) ** 2)
        actual = _choi_distance(U, [0.5, 0.5], np.eye(2))
        assert actual == pytest.approx(2 * np.sin(e) ** 2)  # the dephasing channel's distance
        assert actual <= t["bound"] + 1e-12


@pytest.mark.parametrize("d", [2, 4])
def test_bound_holds_for_random_near_target_unitaries(d):
    for _ in range(20):
        V = _near(np.eye(d), 3.0)
        K = int(RNG.integers(2, 5))
        Us = [_near(V, float(RNG.uniform(0.01, 0.3))) for _ in range(K)]
        alpha = RNG.dirichlet(np.ones(K))
        t = mixing_lemma_terms(Us, alpha, V)
        assert _choi_distance(Us, alpha, V) <= t["bound"] + 1e-10
        for _ in range(3):  # and on every input state
            psi = RNG.normal(size=d) + 1j * RNG.normal(size=d)
            psi /= np.linalg.norm(psi)
            rho = np.outer(psi, psi.conj())
            lam = sum(a * U @ rho @ U.conj().T for a, U in zip(alpha, Us, strict=True))
            assert trace_distance(lam, V @ rho @ V.conj().T) <= t["bound"] + 1e-10


def test_supervised_bound_and_bad_input():
    assert supervised_mixing_bound(0.2, 0.04, 2.0) == pytest.approx(0.04 / 8 + 0.08)
    with pytest.raises(ValueError, match="delta_1"):
        supervised_mixing_bound(-0.1, 0.0)
    with pytest.raises(ValueError, match="observable_norm"):
        supervised_mixing_bound(0.1, 0.1, 0.0)
    with pytest.raises(ValueError, match="alpha has 1 entries"):
        mixing_lemma_terms([np.eye(2), np.eye(2)], [1.0], np.eye(2))
    with pytest.raises(ValueError, match="unitaries\\[1\\] has shape"):
        mixing_lemma_terms([np.eye(2), np.eye(4)], [0.5, 0.5], np.eye(2))
    with pytest.raises(ValueError, match="square"):
        mixing_lemma_terms([np.ones(3)], [1.0], np.eye(3))
    with pytest.raises(ValueError, match="Hermitian"):
        trace_distance(np.array([[0, 1], [0, 0]]), np.zeros((2, 2)))
