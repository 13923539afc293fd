"""Saved estimator files: bit-exact round trips in both formats, and edited or damaged files
refused at ``load`` (naming the field) before any circuit is built."""

from __future__ import annotations

import json

import numpy as np
import pytest

from qdensity.learning.estimators import QNNClassifier, QNNRegressor
from qdensity.learning.parameters import load_parameters, save_parameters

RNG = np.random.default_rng(11)
X = RNG.normal(size=(24, 4))
Y = (X[:, 0] + X[:, 1] > 0).astype(int) + (X[:, 2] > 1).astype(int)


@pytest.fixture(scope="module")
def fitted():
    # num_qubits=3 < 4 features + constant: a PCA step (its matrix is Fortran-ordered)
    return QNNClassifier(num_qubits=3, epochs=1, batch_size=8, verbose=False).fit(X, Y)


@pytest.mark.parametrize("suffix", [".json", ".npz"])
def test_round_trip_is_bit_exact(fitted, tmp_path, suffix):
    path = tmp_path / f"clf{suffix}"
    fitted.save(path)
    back = QNNClassifier().load(path)
    assert back.pca_ is not None
    # exact equality: the same bits, not a tolerance
    assert np.array_equal(back.predict_proba(X), fitted.predict_proba(X))
    assert np.array_equal(back.decision_function(X), fitted.decision_function(X))
    assert np.array_equal(back.predict(X), fitted.predict(X))


def test_regressor_round_trip_is_bit_exact(tmp_path):
    reg = QNNRegressor(num_qubits=3, epochs=1, verbose=False).fit(X, X[:, 0])
    for suffix in (".json", ".npz"):
        reg.save(tmp_path / f"r{suffix}")
        assert np.array_equal(QNNRegressor().load(tmp_path / f"r{suffix}").predict(X),
                              reg.predict(X))


def test_fortran_arrays_keep_their_layout_through_json(tmp_path):
    a = np.asfortranarray(RNG.normal(size=(3, 5)))
    save_parameters(tmp_path / "a.json", a=a, c=np.ones((2, 2)))
    back = load_parameters(tmp_path / "a.json")
    assert back["a"].flags.f_contiguous and not back["a"].flags.c_contiguous
    assert back["c"].flags.c_contiguous
    assert np.array_equal(back["a"], a)


def _edit(fitted, tmp_path, change):
    path = tmp_path / "clf.json"
    fitted.save(path)
    data = load_parameters(path)
    meta = json.loads(bytes(data["meta"]).decode())
    change(meta, data)
    data["meta"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    save_parameters(path, **data)
    return path


def _set(path, value):
    def change(meta, data):
        *head, last = path
        d = meta
        for k in head:
            d = d[k]
        if value is KeyError:
            del d[last]
        else:
            d[last] = value
    return change


@pytest.mark.parametrize(("change", "match"), [
    (_set(["classes"], KeyError), "lacks 'classes'"),
    (_set(["classes"], [1]), "at least 2 distinct"),
    (_set(["classes"], [1, 1, 2]), "at least 2 distinct"),
    (_set(["n_features_in"], KeyError), "lacks 'n_features_in'"),
    (_set(["n_features_in"], "4"), "'n_features_in' must be a int"),
    (_set(["num_qubits"], 1000), r"\(3, 2\)"),
    (_set(["spec", "num_qubits"], 1000), r"give \(1000, 999\)"),
    (_set(["spec", "num_qubits"], 10**6), "num_qubits must be an int >= 2 and <= 4096"),
    (_set(["spec", "depth"], -2), "depth must be an int >= 1"),
    (_set(["spec", "ansatz"], "mystery"), "ansatz must be one of"),
    (_set(["spec", "extra"], 1), "exactly"),
    (_set(["template"], True), "DensityQNN template"),
    (_set(["estimator"], "QNNRegressor"), "not a QNNClassifier"),
    (_set(["post"], False), "arrays"),
    (lambda meta, data: data.pop("pca_mean"), "arrays"),
    (lambda meta, data: data.update(pca_components=np.ones((3, 4))), "pca_components"),
    (lambda meta, data: data.update(part1=np.ones(7)), "part1 .post. has 7 entries"),
    (lambda meta, data: data.update(part0=np.ones(1)), "part0"),
])
def test_edited_files_are_refused_before_building(fitted, tmp_path, change, match):
    path = _edit(fitted, tmp_path, change)
    with pytest.raises(ValueError, match=match):
        QNNClassifier().load(path)


def test_both_sizes_edited_is_caught_by_the_read_out(fitted, tmp_path):
    def change(meta, data):
        meta["spec"]["num_qubits"] = 1000
        meta["num_qubits"], meta["data_columns"] = 1000, 999
        meta["n_features_in"] = 999
        data.pop("pca_components"), data.pop("pca_mean")
    path = _edit(fitted, tmp_path, change)
    with pytest.raises(ValueError, match="too few for a model on 1000 qubits"):
        QNNClassifier().load(path)

    def grow(meta, data):  # enough angles, but the read-out still betrays the width
        change(meta, data)
        data["part0"] = np.zeros(5000)
    path = _edit(fitted, tmp_path, grow)
    with pytest.raises(ValueError, match=r"part1 \(post\) has 12 entries, expected 3003"):
        QNNClassifier().load(path)
