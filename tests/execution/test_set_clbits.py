"""Sampled results read as sparse set clbits (device widths): the packed bytes' set bits, the
unary frequencies from them and every output's gradient estimate on them, each checked against
an oracle computed shot by shot from the boolean bits."""

from __future__ import annotations

import numpy as np
import pytest
from qiskit.primitives import BitArray

from qdensity.analysis.pauli import ZStringTable
from qdensity.execution.job_results import JobResult, unary_frequencies
from qdensity.execution.sampler._packed_result import PackedJobResult
from qdensity.gradients._circuits import _raw_means


def _packed(bits: np.ndarray) -> PackedJobResult:
    """A PackedJobResult of boolean bits (rows, shots, m), packed by qiskit's own BitArray."""
    rows, shots, m = bits.shape
    ba = BitArray.from_bool_array(bits.reshape(rows * shots, m), order="little")
    return PackedJobResult(ba, rows, shots)


@pytest.mark.parametrize("m", [1, 7, 8, 9, 63, 64, 65, 130, 1024])
@pytest.mark.parametrize("density", [0.0, 0.02, 0.5, 1.0])
def test_set_clbits_of_packed_shots_are_the_true_bits(m, density):
    rng = np.random.default_rng(m)
    bits = rng.random((3, 40, m)) < density
    res = _packed(bits)
    shot, clbit = res.set_clbits()
    want = set(zip(*np.nonzero(bits.reshape(120, m)), strict=True))
    assert set(zip(shot.tolist(), clbit.tolist(), strict=True)) == want
    assert shot.size == len(want) and np.all(np.diff(shot) >= 0)
    assert res.bits_shape == (3, 40, m) and res.has_bits
    plain = JobResult(None, 40, None, bits=bits)
    assert set(zip(*plain.set_clbits(), strict=True)) == want and plain.bits_shape == (3, 40, m)


def _hamming_like(rng, rows, shots, m, flip):
    """One-hot shots, then each bit flipped with probability ``flip`` (a readout error)."""
    bits = np.zeros((rows, shots, m), bool)
    bits[np.arange(rows)[:, None], np.arange(shots)[None, :],
         rng.integers(0, m, (rows, shots))] = True
    return bits ^ (rng.random(bits.shape) < flip)


@pytest.mark.parametrize("flip", [0.0, 0.05])
@pytest.mark.parametrize("postselect", [False, True])
def test_unary_frequencies_from_packed_shots_count_the_weight_one_shots(flip, postselect):
    rng = np.random.default_rng(3)
    rows, shots, m = 4, 300, 37
    bits = _hamming_like(rng, rows, shots, m, flip)
    p, kept, se = unary_frequencies(_packed(bits), postselect, return_std=True)
    for r in range(rows):  # the oracle: shot by shot
        one = [s for s in range(shots) if bits[r, s].sum() == 1]
        counts = np.zeros(m)
        for s in one:
            counts[np.flatnonzero(bits[r, s])[0]] += 1
        assert kept[r] == len(one) / shots
        n = len(one) if postselect else shots
        np.testing.assert_allclose(p[r], counts / n, rtol=0, atol=1e-15)
        q = counts / n  # binomial error of each frequency, Wilson-floored: never zero
        np.testing.assert_allclose(se[r], np.sqrt(q * (1 - q) / n + 1 / (4 * n**2)), atol=1e-15)


def test_every_tables_mean_and_error_on_set_bits_equal_the_per_shot_ones():
    # several tables (outputs) on the same shots, as a density gradient reads one circuit
    # for all its outputs; oracle: each shot's value by its parities, then mean and ddof=1
    rng = np.random.default_rng(11)
    rows, shots, m, P = 3, 250, 12, 4
    tables = []
    for t in range(5):
        z = rng.random((3 + t, m)) < 0.2
        z[0] = False  # a constant string (no bits): in the mean, not in the range
        coeffs = rng.normal(size=(3 + t, P)) * (rng.random((3 + t, P)) < 0.6)
        coeffs[:, t % P] = 0.0  # a column no string weighs on: 0 with error 0
        tables.append(ZStringTable(z, coeffs))
    bits = _hamming_like(rng, rows, shots, m, 0.1)
    shot, clbit = _packed(bits).set_clbits()
    mean, se = _raw_means(tables, shot, clbit, rows, shots)
    assert mean.shape == se.shape == (rows, len(tables), P)
    for t, table in enumerate(tables):
        per_shot = np.array([[[sum(table.coefficients[k, p] * (-1) ** int(np.sum(b & table.z[k]))
                                   for k in range(table.z.shape[0])) for p in range(P)]
                              for b in row] for row in bits])  # (rows, shots, P)
        np.testing.assert_allclose(mean[:, t], per_shot.mean(axis=1), atol=1e-12)
        R = 2 * np.abs(table.coefficients[table.z.any(axis=1)]).sum(axis=0)
        want = np.sqrt(per_shot.var(axis=1, ddof=1) / shots + R**2 / (4 * shots**2))
        np.testing.assert_allclose(se[:, t], want, atol=1e-12)
        assert np.all(mean[:, t, t % P] == 0) and np.all(se[:, t, t % P] == 0)
