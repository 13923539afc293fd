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
        meta["spec"]["scale"] = False  # the scaler's arrays would betray the width at once
        data.pop("pca_components"), data.pop("pca_mean")
        data.pop("scaler_mean"), data.pop("scaler_scale")
    path = _edit(fitted, tmp_path, change)
    with pytest.raises(ValueError, match="499500 circuit angles, more than the 16384"):
        QNNClassifier().load(path)

    def grow(meta, data):  # every size consistent: still refused before building
        change(meta, data)
        data["part0"] = np.zeros(499500 + 3)
        data["part1"] = np.zeros(1000 * 3 + 3)
    path = _edit(fitted, tmp_path, grow)
    with pytest.raises(ValueError, match="499500 circuit angles.*refused before building"):
        QNNClassifier().load(path)


def test_too_few_angles_for_the_spec_are_refused(fitted, tmp_path):
    # round-robin on 3 qubits has 3 angles: 2 (n - 1, the old lower bound) is refused now
    path = _edit(fitted, tmp_path, lambda meta, data: data.update(part0=np.zeros(2)))
    with pytest.raises(ValueError, match="part0 has 2 entries, too few.*3 angles"):
        QNNClassifier().load(path)


@pytest.mark.parametrize("n", list(range(2, 18)))
def test_spec_angles_are_the_built_circuits(n):
    from qdensity.circuits.ansatze import FAMILIES, estimator_ansatze
    from qdensity.learning._saved import spec_angles

    for ansatz in estimator_ansatze():
        build = FAMILIES[ansatz].builder
        if ansatz == "butterfly" and n & (n - 1):
            continue  # a butterfly needs a power of two
        spec = {"ansatz": ansatz, "decomposition": "layers", "depth": 2}
        assert spec_angles(spec, n) == build(n).num_parameters, (ansatz, n)


def _npz_with_member(path, name: str, header_shape, payload: bytes, deflate=False):
    import io
    import zipfile

    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buf, {"descr": "<f8", "fortran_order": False, "shape": header_shape})
    comp = zipfile.ZIP_DEFLATED if deflate else zipfile.ZIP_STORED
    with zipfile.ZipFile(path, "w", compression=comp) as zf:
        zf.writestr(name, buf.getvalue() + payload)


def test_members_are_measured_from_the_zip_headers_before_inflating(tmp_path):
    path = tmp_path / "big.npz"
    # 64 MB of zeros deflate to ~64 KB; the header says 64 MB: refused without inflating
    _npz_with_member(path, "part0.npy", (8 * 2**20,), bytes(64 * 2**20), deflate=True)
    assert path.stat().st_size < 2**20
    with pytest.raises(ValueError, match=r"big.npz.*inflate to 67108\d+ bytes, more than the "
                                         r"1000000 allowed; refused before inflating"):
        load_parameters(path, max_bytes=10**6)
    with pytest.raises(ValueError, match="inflate to .* more than"):
        QNNClassifier().load(path)  # estimator files: 64 MiB at most


def test_an_array_claiming_more_than_its_member_is_refused(tmp_path):
    path = tmp_path / "liar.npz"
    _npz_with_member(path, "part0.npy", (10**10,), bytes(16))  # 80 GB claimed, 16 B held
    with pytest.raises(ValueError, match=r"liar.npz.*part0.npy.*claims shape \(10000000000,\)"):
        load_parameters(path)


def test_deeply_nested_json_is_a_clear_error(tmp_path):
    path = tmp_path / "deep.json"
    path.write_text("[" * 200_000 + "]" * 200_000)
    with pytest.raises(ValueError, match="deep.json.*nests deeper"):
        load_parameters(path)
    with pytest.raises(ValueError, match="deep.json"):
        QNNClassifier().load(path)


def test_a_file_from_before_scale_loads_as_unscaled(tmp_path):
    X = np.random.default_rng(1).normal(size=(30, 4))
    Y = (X[:, 0] > 0).astype(int)
    old = QNNClassifier(num_qubits=3, scale=False, epochs=1, verbose=False).fit(X, Y)

    def drop(meta, data):  # what save wrote before the scale parameter existed
        del meta["spec"]["scale"]
    back = QNNClassifier().load(_edit(old, tmp_path, drop))
    assert back.scale is False and back.scaler_ is None
    np.testing.assert_allclose(back.predict_proba(X), old.predict_proba(X))


def test_scaler_arrays_are_checked(fitted, tmp_path):
    def shrink(meta, data):
        data["scaler_mean"] = data["scaler_mean"][:2]
    with pytest.raises(ValueError, match="scaler_mean has shape"):
        QNNClassifier().load(_edit(fitted, tmp_path, shrink))
