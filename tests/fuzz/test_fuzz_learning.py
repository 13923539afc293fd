"""Fuzzing ``qdensity.learning`` parameter files (``save_parameters`` / ``load_parameters``).

Valid: random finite arrays round-trip exactly through ``.npz`` and JSON. Invalid files
(empty, random bytes, a flipped byte, pickles, truncated or inconsistent JSON, NaN) raise a
``ValueError`` that names the file, never ``EOFError``, ``BadZipFile`` or a bare reshape error.
(The estimators' hyperparameter checks live with the scikit-learn estimators' ``fit``.)
"""

from __future__ import annotations

import json
import os
import pickle
import tempfile

import numpy as np
import pytest
from _fuzz import TALLY, accepted, refused
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from qdensity.learning.parameters import load_parameters, save_parameters

ARRAYS = hnp.arrays(np.float64, hnp.array_shapes(min_dims=0, max_dims=3, max_side=4),
                    elements=st.floats(-1e6, 1e6, allow_nan=False))


def _write(path: str, data: bytes) -> str:
    with open(path, "wb") as fh:
        fh.write(data)
    return path


def _refused_naming(path: str) -> None:
    exc = refused("load_parameters", load_parameters, path)
    assert isinstance(exc, ValueError) and repr(os.fspath(path)) in str(exc)


# ----------------------------------------------------------------------------- found cases
def test_found_bad_parameter_files_name_the_file(tmp_path):
    good = tmp_path / "good.npz"
    save_parameters(good, theta=np.arange(6.0))
    raw = good.read_bytes()
    cases = {
        "empty.npz": b"",
        "random.npz": bytes(np.random.default_rng(0).integers(0, 256, 300, dtype=np.uint8)),
        "flipped.npz": raw[:60] + bytes([raw[60] ^ 0xFF]) + raw[61:],
        "pickle.npz": pickle.dumps({"theta": np.zeros(2)}),
    }
    messages = {}
    for name, data in cases.items():
        path = _write(str(tmp_path / name), data)
        with pytest.raises(ValueError) as info:
            load_parameters(path)
        assert repr(path) in str(info.value)
        messages[name] = str(info.value)
    assert "empty file" in messages["empty.npz"]
    assert "pickled data" not in messages["random.npz"]
    short = tmp_path / "short.json"
    short.write_text(json.dumps({"format": "qdensity-parameters", "arrays": {
        "theta": {"dtype": "<f8", "shape": [2, 3], "data": [1.0, 2.0]}}}))
    with pytest.raises(ValueError, match=r"short.json.*'theta' has 2 values.*needs 6"):
        load_parameters(short)
    nan_file = tmp_path / "nan.npz"
    with pytest.raises(ValueError, match="NaN or inf"):
        save_parameters(nan_file, theta=np.array([0.0, np.nan]))
    np.savez(nan_file, theta=np.array([0.0, np.nan]))
    with pytest.raises(ValueError, match=r"nan.npz.*'theta' holds NaN"):
        load_parameters(nan_file)


# ----------------------------------------------------------------------------- valid input
@settings(max_examples=20)
@given(arr=ARRAYS, suffix=st.sampled_from([".npz", ".json"]))
def test_parameters_round_trip(arr, suffix):
    accepted("load_parameters")
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "p" + suffix)
        save_parameters(path, theta=arr)
        back = load_parameters(path)["theta"]
    assert back.shape == arr.shape and back.dtype == arr.dtype
    np.testing.assert_array_equal(back, arr)


# ----------------------------------------------------------------------------- invalid input
@settings(max_examples=40)
@given(data=st.data())
def test_damaged_npz_refused(data):
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "p.npz")
        save_parameters(path, theta=np.arange(5.0), W=np.eye(2))
        raw = bytearray(open(path, "rb").read())
        kind = data.draw(st.sampled_from(["flip", "truncate", "random"]))
        if kind == "flip":
            # inside the stored arrays' headers/data (flips elsewhere can leave a valid file)
            i = data.draw(st.integers(0, len(raw) - 1))
            raw[i] ^= data.draw(st.integers(1, 255))
        elif kind == "truncate":
            raw = raw[: data.draw(st.integers(0, len(raw) - 1))]
        else:
            raw = bytearray(data.draw(st.binary(max_size=200)))
        _write(path, bytes(raw))
        try:
            out = load_parameters(path)
        except ValueError as exc:
            TALLY["load_parameters"] += 1  # a refused bad file
            assert repr(path) in str(exc)
            return
        # a flip in a place that does not matter (a timestamp, padding) still loads cleanly
        accepted("load_parameters")
        assert all(np.all(np.isfinite(v)) for v in out.values() if v.dtype.kind == "f")


@settings(max_examples=40)
@given(doc=st.one_of(
    st.text(max_size=30),
    st.recursive(st.none() | st.booleans() | st.floats(allow_nan=False) | st.text(max_size=4),
                 lambda c: st.lists(c, max_size=3) | st.dictionaries(st.text(max_size=5), c,
                                                                     max_size=3),
                 max_leaves=8).map(json.dumps),
    st.builds(lambda shape, data, dtype: json.dumps(
        {"format": "qdensity-parameters",
         "arrays": {"theta": {"dtype": dtype, "shape": shape, "data": data}}}),
        st.lists(st.integers(-2, 4), max_size=3),
        st.one_of(st.lists(st.floats(-1, 1), max_size=5), st.text(max_size=3)),
        st.sampled_from(["<f8", "<i8", "object", "<U3", "nonsense", "<c16"]))))
def test_bad_json_refused_or_consistent(doc):
    with tempfile.TemporaryDirectory() as tmp:
        path = _write(os.path.join(tmp, "p.json"), doc.encode())
        try:
            out = load_parameters(path)
        except ValueError as exc:
            TALLY["load_parameters"] += 1  # a refused bad file
            assert repr(path) in str(exc)
            return
        accepted("load_parameters")
        entry = json.loads(doc)["arrays"]["theta"]
        assert out["theta"].shape == tuple(entry["shape"])
