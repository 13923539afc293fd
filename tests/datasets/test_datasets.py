"""Datasets against their definitions: clean bars-and-dots patterns, Chebyshev polynomials in
closed form, noise statistics within standard errors, seeded reproducibility, and the digits
PCA fitted on the training split only."""

from __future__ import annotations

import math

import numpy as np

from qdensity.datasets import bars_and_dots, chebyshev_dataset, load_digits_features


def test_bars_and_dots_clean_patterns_and_labels():
    d = 6
    X, y = bars_and_dots(200, d, noise_std=0.0, seed=3)
    assert X.shape == (200, d) and y.shape == (200,)
    assert set(np.unique(y)) == {-1, 1}
    bar = np.array([-1, -1, -1, 1, 1, 1.0])
    dot = np.array([-1, 1, -1, 1, -1, 1.0])
    for row, label in zip(X, y, strict=True):
        template = bar if label == 1 else dot
        assert any(np.array_equal(row, np.roll(template, s)) for s in range(d))
    # odd dimension: floor(d/2) minus signs in a run (bar) or two apart (dot)
    X5, y5 = bars_and_dots(100, 5, noise_std=0.0, seed=4)
    for row, label in zip(X5, y5, strict=True):
        template = np.array([-1, -1, 1, 1, 1.0]) if label == 1 else np.array([-1, 1, -1, 1, 1.0])
        assert any(np.array_equal(row, np.roll(template, s)) for s in range(5))


def test_bars_and_dots_noise_balance_and_seeding():
    n, d, sigma = 4000, 8, 1.8
    X, y = bars_and_dots(n, d, noise_std=sigma, seed=11)
    X2, y2 = bars_and_dots(n, d, noise_std=sigma, seed=11)
    np.testing.assert_array_equal(X, X2)
    np.testing.assert_array_equal(y, y2)
    assert not np.array_equal(X, bars_and_dots(n, d, noise_std=sigma, seed=12)[0])
    clean, _ = bars_and_dots(n, d, noise_std=0.0, seed=11)
    residual = X - clean  # same seed -> same labels and shifts, noise drawn last
    # sample std of N = 32000 normals: standard error sigma / sqrt(2N) ~ 0.007
    assert abs(residual.std() - sigma) < 5 * sigma / math.sqrt(2 * residual.size)
    assert abs(residual.mean()) < 5 * sigma / math.sqrt(residual.size)
    assert abs(np.mean(y == 1) - 0.5) < 5 * 0.5 / math.sqrt(n)
    gen = np.random.default_rng(5)
    assert bars_and_dots(3, 4, 0.1, seed=gen)[0].shape == (3, 4)


def test_chebyshev_dataset():
    X, y = chebyshev_dataset(500, degree=4, noise_std=0.0, seed=1)
    assert X.shape == (500, 1) and y.shape == (500,)
    x = X[:, 0]
    assert np.all((x >= -1) & (x <= 1))
    np.testing.assert_allclose(y, np.cos(4 * np.arccos(x)), atol=1e-12)
    np.testing.assert_allclose(y, 8 * x**4 - 8 * x**2 + 1, atol=1e-12)
    for k in (0, 1, 5):
        Xk, yk = chebyshev_dataset(50, degree=k, noise_std=0.0, seed=2)
        np.testing.assert_allclose(yk, np.cos(k * np.arccos(Xk[:, 0])), atol=1e-12)
    n = 20000
    Xn, yn = chebyshev_dataset(n, noise_std=0.5, seed=9)
    Xn2, yn2 = chebyshev_dataset(n, noise_std=0.5, seed=9)
    np.testing.assert_array_equal(Xn, Xn2)
    np.testing.assert_array_equal(yn, yn2)
    resid = yn - np.cos(4 * np.arccos(Xn[:, 0]))
    assert abs(resid.var() - 0.25) < 5 * 0.25 * math.sqrt(2 / n)
    assert abs(resid.mean()) < 5 * 0.5 / math.sqrt(n)


def test_digits_pca_is_fitted_on_the_training_split_only():
    from sklearn.datasets import load_digits

    X_tr, X_te, y_tr, y_te = load_digits_features(num_features=5, test_size=300, seed=2)
    n_all = len(load_digits().target)
    assert X_tr.shape == (n_all - 300, 5) and X_te.shape == (300, 5)
    assert y_tr.shape == (n_all - 300,) and y_te.shape == (300,)
    # PCA centres on the training mean: training scores have zero mean, test scores do not
    np.testing.assert_allclose(X_tr.mean(axis=0), 0.0, atol=1e-9)
    assert np.abs(X_te.mean(axis=0)).max() > 1e-6
    # components are ordered by explained variance on the training data
    assert np.all(np.diff(X_tr.var(axis=0)) <= 1e-9)
    # stratified: every class appears in the test split in proportion
    counts = np.bincount(y_te, minlength=10)
    assert counts.min() >= 25 and counts.max() <= 35
    again = load_digits_features(num_features=5, test_size=300, seed=2)
    np.testing.assert_array_equal(again[0], X_tr)


def test_chebyshev_split_follows_supp_j():
    from qdensity.datasets import chebyshev_split

    X_tr, X_te, y_tr, y_te = chebyshev_split(2, 0.2, seed=4)
    assert X_tr.shape == (25, 1) and X_te.shape == (110, 1)
    np.testing.assert_allclose(X_te[:, 0], np.linspace(-1, 1, 110))
    np.testing.assert_allclose(y_te, np.cos(2 * np.arccos(X_te[:, 0])), atol=1e-12)
    resid = y_tr - np.cos(2 * np.arccos(X_tr[:, 0]))
    assert 0.0 < resid.std() < 0.2 + 5 * 0.2 / math.sqrt(2 * 25)
