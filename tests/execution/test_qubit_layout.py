"""The moving qubit layout of the compiled adjoint kernels (statevector._layout): the
plan's invariants, and the permutation kernel against numpy's transpose. Values and gradients
in a moving layout are tested against Qiskit in test_adjoint.py."""

from __future__ import annotations

import numpy as np
import pytest

from qdensity.execution import _numba
from qdensity.execution.statevector import _layout


def test_plan_keeps_gates_off_the_low_bits_and_ends_at_home():
    """Replaying the plan's permutations from the identity gives each operation's layout, in
    which no touched qubit sits below the low bits; the last layout is the identity."""
    rng = np.random.default_rng(7)
    n, low = 12, 4
    masks = []
    for _ in range(300):
        qs = rng.choice(n, size=rng.integers(1, 4), replace=False)
        masks.append(int(sum(1 << int(q) for q in qs)))
    steps = _layout.plan(masks, n, low)
    phys = list(range(n))
    seen = []
    for step in steps:
        if step[0] == "perm":
            dest = step[1]
            assert sorted(dest.tolist()) == list(range(n))
            phys = [int(dest[b]) for b in phys]
            continue
        _, i, layout = step
        assert list(layout) == phys
        seen.append(i)
        assert all(phys[q] >= low for q in range(n) if masks[i] >> q & 1)
    assert seen == list(range(len(masks)))
    assert phys == list(range(n))
    assert 0 < sum(s[0] == "perm" for s in steps) < len(masks) / 2


def test_plan_keeps_the_identity_when_there_is_no_room():
    masks = [0b111, 0b1001]
    assert _layout.plan(masks, 5, 2) == [("op", 0, tuple(range(5))), ("op", 1, tuple(range(5)))]


def _transposed(state: np.ndarray, dest: np.ndarray) -> np.ndarray:
    """Bit ``b`` of every index moved to ``dest[b]``, by numpy's transpose (bit ``b`` is
    tensor axis ``n - 1 - b``)."""
    n = dest.size
    axes = [0] * n
    for b in range(n):
        axes[n - 1 - int(dest[b])] = n - 1 - b
    return np.transpose(state.reshape((2,) * n), axes).reshape(-1)


def test_permute_kernel_moves_bits_like_a_transpose():
    if not _numba.available():
        pytest.skip("QDENSITY_NUMBA=0 switches the compiled kernels off")
    from qdensity.execution.statevector import _kernels_planar

    rng = np.random.default_rng(3)
    n = 10
    swap = np.arange(n)
    swap[[0, 5, 2, 9]] = [5, 0, 9, 2]
    cycle = np.arange(n)
    cycle[[1, 3, 7]] = [3, 7, 1]
    high = np.arange(n)
    high[[4, 8]] = [8, 4]
    for dest in (swap, cycle, high, rng.permutation(n)):
        state = rng.normal(size=2**n) + 1j * rng.normal(size=2**n)
        free, offs, src, back = _layout.tile(dest)
        re, im = state.real.copy(), state.imag.copy()
        br, bi = np.empty(offs.size), np.empty(offs.size)
        _kernels_planar.permute(re, im, n, np.concatenate([[free, offs.size], offs, src]), br, bi)
        np.testing.assert_array_equal(re + 1j * im, _transposed(state, dest))
        _kernels_planar.permute(re, im, n, np.concatenate([[free, offs.size], offs, back]), br, bi)
        np.testing.assert_array_equal(re + 1j * im, state)
