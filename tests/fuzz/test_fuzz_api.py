"""The net over the public API: every constructor and entry point, every argument, bad values.

Each row of :data:`ENTRIES` is an entry point with a valid call; each of its arguments gets
bad values of the kinds that argument can be wrong in (wrong type, NaN/inf, negative, empty,
huge, a string where an object belongs). The call must raise ``ValueError`` or ``TypeError``
whose message names the argument, within hypothesis' deadline of 20 s per call (a builder that
tries to honour ``10**9`` qubits, or a file that builds before it checks, runs for minutes and
fails it; the margin keeps a busy machine from failing it).
"""

from __future__ import annotations

import math
from datetime import timedelta

import numpy as np
import pytest
from _fuzz import refused
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from qdensity.circuits.ansatze import (
    butterfly,
    hardware_efficient,
    pyramid,
    qcnn,
    reuploading,
    round_robin,
    x_circuit,
)
from qdensity.circuits.loaders import unary_loader
from qdensity.cli._builders import build_circuit
from qdensity.datasets.bars_and_dots import bars_and_dots
from qdensity.datasets.chebyshev import chebyshev_dataset
from qdensity.datasets.digits import load_digits_features
from qdensity.execution.exact import ExactEngine
from qdensity.execution.sampler.engine import SamplerEngine, ShotLedger
from qdensity.learning.estimators import QNNClassifier, QNNRegressor
from qdensity.learning.layer import QuantumLayer
from qdensity.learning.nn import Linear
from qdensity.models.density import DensityQNN, Encoding
from qdensity.models.lcu import LCUQNN
from qdensity.models.mixtures import FixedMixture, GatedMixture, SoftmaxMixture
from qdensity.models.single_qubit import SingleQubitReuploading
from qdensity.validation import as_rng, seed_int
from qdensity_paper.results import bootstrap_ci

# ----------------------------------------------------------------------------- bad values
OBJ = st.sampled_from(["notanengine", "", 3, 2.5, object(), ("a", 1)])
SEED = st.one_of(st.integers(-10**9, -1), st.floats(allow_nan=True), st.text(max_size=3),
                 st.just([1, 2]), st.booleans())
SIZE = st.one_of(st.integers(-10**6, 0), st.floats(allow_nan=True), st.text(max_size=3),
                 st.booleans())
HUGE_SIZE = st.one_of(SIZE, st.integers(10**9, 10**12))
REAL_POS = st.one_of(st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -1.0, -1e300]),
                     st.text(max_size=3), st.just([1.0]), st.none())
CHOICE = st.one_of(st.text(max_size=6).filter(lambda t: t not in ("exact", "")),
                   st.integers(), st.none(), st.just(["a"]))
BOOL = st.sampled_from([1, 0, "yes", None, 2.0])


def _array(shape, *, empty: bool = True):
    """Arrays of the right shape poisoned with NaN/inf, wrong shapes, strings, empty."""
    n = int(np.prod(shape))
    kinds = [st.sampled_from([math.nan, math.inf, -math.inf]).map(
        lambda v: np.full(shape, v)),
        st.just(np.zeros(tuple(s + 1 for s in shape))),
        st.just("abc"),
        st.just(np.full(shape, "a"))]
    if empty:
        kinds.append(st.just(np.zeros((0,) * len(shape))))
    if n > 1:
        kinds.append(st.integers(0, n - 1).map(
            lambda i: np.where(np.arange(n) == i, np.nan, 1.0).reshape(shape)))
    return st.one_of(*kinds)


# ----------------------------------------------------------------------------- the entries
N = 4
X1 = [1.0, 2.0, 3.0, 4.0]
XS = np.random.default_rng(0).normal(size=(12, 3))
YS = np.array([0, 1, 2] * 4)


def _density(**kw):
    args = {"sub_unitaries": [round_robin(N)], "mixture": None, "encoding": Encoding.unary(N),
            "readout": "unary_probabilities", "seed": 0}
    args.update(kw)
    return DensityQNN(args.pop("sub_unitaries"), args.pop("mixture"), **args)


OBSERVED = DensityQNN([round_robin(N)], encoding=Encoding.unary(N), readout="observable")


def _sample(**kw):
    args = {"x": X1, "budget": 100, "scheduler": "per_shot", "engine": None, "target": None,
            "seed": 0}
    args.update(kw)
    return OBSERVED.sample(args.pop("x"), args.pop("budget"), **args)


def _fit(est):
    def call(**kw):
        X, y = kw.pop("X", XS), kw.pop("y", YS)
        return est(**{"epochs": 1, "verbose": False, **kw}).fit(X, y)
    return call


def _call(fn, *positional):
    """``fn`` with its leading positional arguments given by keyword in the table."""
    def call(**kw):
        args = [kw.pop(p) for p in positional]
        return fn(*args, **kw)
    return call


def _ledger(**kw):
    return ShotLedger().record(**kw)


ENTRIES = {
    # name: (callable(**kw), valid kwargs, {argument: bad values})
    "DensityQNN": (_density, {}, {
        "sub_unitaries": st.one_of(OBJ, st.just([]), st.just([round_robin(3), round_robin(4)])),
        "mixture": st.one_of(st.just("softmax"), st.just([0.5, 0.6]), st.just([math.nan])),
        "encoding": OBJ, "readout": CHOICE, "seed": SEED}),
    "DensityQNN.sample": (_sample, {}, {
        "x": _array((N,)), "budget": HUGE_SIZE,
        "scheduler": CHOICE, "engine": OBJ, "target": OBJ, "seed": SEED}),
    "LCUQNN": (_call(LCUQNN, "sub_unitaries"), {"sub_unitaries": [round_robin(N)]},
               {"sub_unitaries": st.one_of(OBJ, st.just([])), "seed": SEED}),
    "GatedMixture": (_call(GatedMixture, "num_features", "num_components"),
                     {"num_features": 4, "num_components": 2}, {
        "num_features": HUGE_SIZE, "num_components": HUGE_SIZE,
        "activation": CHOICE.filter(lambda v: v is not None),
        "weights": _array((2, 4)), "bias": _array((2,)), "seed": SEED}),
    "SoftmaxMixture": (_call(SoftmaxMixture, "num_components"), {"num_components": 3},
                       {"num_components": HUGE_SIZE}),
    "FixedMixture": (_call(FixedMixture, "alpha"), {"alpha": [0.5, 0.5]},
                     {"alpha": st.one_of(_array((2,)), st.just([0.7, 0.7]),
                                         st.just([-0.5, 1.5]))}),
    "Encoding.unary": (_call(Encoding.unary, "num_features"), {"num_features": 4},
                       {"num_features": HUGE_SIZE, "layout": CHOICE}),
    "SamplerEngine": (SamplerEngine, {}, {
        "sampler": OBJ.filter(lambda v: v is not None), "target": OBJ, "transpiler": OBJ,
        "seed": SEED, "ledger": OBJ, "default_shots": SIZE,
        "optimization_level": st.one_of(SIZE.filter(lambda v: v != 0), st.integers(4, 100)),
        "progress": BOOL}),
    "ExactEngine": (ExactEngine, {}, {"method": CHOICE, "device": CHOICE}),
    "ShotLedger.record": (_ledger, {"label": "x", "circuits": 1, "shots": 10}, {
        "label": st.sampled_from([3, None, 2.5]),
        "circuits": st.one_of(st.integers(-10**6, -1), st.floats(), st.text(max_size=2)),
        "shots": st.one_of(st.integers(-10**6, -1), st.floats(), st.text(max_size=2))}),
    "QNNClassifier.fit": (_fit(QNNClassifier), {}, {
        "X": st.one_of(_array((12, 3)), st.just(np.full((12, 3), 1e200))),
        "ansatz": CHOICE, "decomposition": CHOICE, "depth": HUGE_SIZE, "mixture": CHOICE,
        "readout": CHOICE, "num_qubits": HUGE_SIZE, "constant": REAL_POS.filter(
            lambda v: v is not None), "optimizer": CHOICE, "learning_rate": REAL_POS,
        "l2": st.sampled_from([-1.0, math.nan, math.inf, "a"]), "epochs": SIZE,
        "batch_size": SIZE, "engine": OBJ, "gradient": CHOICE, "max_steps": SIZE,
        "max_shots": SIZE, "seed": SEED, "verbose": BOOL, "callback": OBJ, "callbacks": OBJ,
        "pre": OBJ, "post": OBJ}),
    "QNNClassifier.fit(shots)": (_fit(QNNClassifier), {"engine": SamplerEngine(seed=0),
                                                        "shots": 2, "max_steps": 1}, {
        "shots": st.one_of(SIZE, st.just(1))}),
    "QNNRegressor.fit": (_fit(QNNRegressor), {"y": XS[:, 0]}, {
        "y": st.one_of(_array((12,), empty=False), st.just(np.full(12, 1e200)),
                       st.just(np.full(12, -1e300)))}),
    "QuantumLayer": (_call(QuantumLayer, "model"), {"model": _density()}, {
        "engine": OBJ, "gradient": CHOICE}),
    "QuantumLayer(shots)": (_call(QuantumLayer, "model"),
                            {"model": _density(), "engine": SamplerEngine(seed=0), "shots": 2},
                            {"shots": st.one_of(SIZE, st.just(1), st.none())}),
    "Linear": (_call(Linear, "in_features", "out_features"),
               {"in_features": 2, "out_features": 3}, {
        "in_features": HUGE_SIZE, "out_features": HUGE_SIZE, "seed": SEED, "bias": BOOL}),
    "SingleQubitReuploading": (_call(SingleQubitReuploading, "num_layers"),
                               {"num_layers": 2}, {
        "num_layers": HUGE_SIZE, "num_subunitaries": HUGE_SIZE, "encoding": CHOICE,
        "seed": SEED}),
    "unary_loader": (_call(unary_loader, "x"), {"x": X1}, {
        "x": st.one_of(_array((N,)), st.just([0.0, 0.0]), st.just([1.0]))}),
    "bars_and_dots": (_call(bars_and_dots, "num_samples", "num_qubits"),
                      {"num_samples": 4, "num_qubits": 4}, {
        "num_samples": HUGE_SIZE, "num_qubits": HUGE_SIZE, "seed": SEED}),
    "chebyshev_dataset": (_call(chebyshev_dataset, "num_samples"), {"num_samples": 5}, {
        "num_samples": HUGE_SIZE, "seed": SEED}),
    "load_digits_features": (load_digits_features, {"num_features": 4, "test_size": 100},
                             {"seed": SEED}),
    "bootstrap_ci": (_call(bootstrap_ci, "values"), {"values": [1.0, 2.0, 3.0]}, {
        "values": st.one_of(_array((3,)).filter(lambda v: np.shape(v) != (4,)),
                            st.just([1.0])), "seed": SEED}),
    "build_circuit": (_call(build_circuit, "name", "num_qubits"),
                      {"name": "pyramid", "num_qubits": 4}, {
        "name": CHOICE, "num_qubits": HUGE_SIZE, "bind_seed": SEED}),
    "as_rng": (as_rng, {"seed": 0}, {"seed": SEED}),
    "seed_int": (seed_int, {"seed": 0}, {"seed": SEED}),
}
for _name, _builder in {"round_robin": round_robin, "pyramid": pyramid, "x_circuit": x_circuit,
                        "butterfly": butterfly, "qcnn": qcnn}.items():
    ENTRIES[_name] = (_call(_builder, "num_qubits"), {"num_qubits": 4},
                      {"num_qubits": HUGE_SIZE})
ENTRIES["hardware_efficient"] = (_call(hardware_efficient, "num_qubits", "reps"),
                                 {"num_qubits": 4, "reps": 2},
                                 {"num_qubits": HUGE_SIZE, "reps": HUGE_SIZE})
ENTRIES["reuploading"] = (_call(reuploading, "layers"), {"layers": 2},
                          {"layers": HUGE_SIZE, "encoding": CHOICE})

CASES = [(entry, arg) for entry, (_, _, bad) in ENTRIES.items() for arg in bad]
#: Arguments whose message names them in another spelling (the positional's role).
SPELLING = {("DensityQNN", "mixture"): ("mixture", "alpha", "components"),
            ("DensityQNN", "sub_unitaries"): ("sub_unitaries",),
            ("QNNClassifier.fit", "X"): ("X",), ("QNNRegressor.fit", "y"): ("y",)}


def test_every_entry_is_valid_as_given():
    """The valid calls run (so a refusal below is the bad argument's doing)."""
    for fn, valid, _ in ENTRIES.values():
        fn(**valid)


@pytest.mark.parametrize(("entry", "arg"), CASES, ids=[f"{e}-{a}" for e, a in CASES])
@settings(max_examples=6, deadline=timedelta(seconds=20),
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_bad_argument_is_refused_by_name(entry, arg, data):
    fn, valid, bad = ENTRIES[entry]
    value = data.draw(bad[arg], label=arg)
    exc = refused(entry, fn, **{**valid, arg: value})
    names = SPELLING.get((entry, arg), (arg,))
    assert any(n in str(exc) for n in names), (
        f"{entry}: the message for a bad {arg}={value!r:.60} does not name it: {exc}")


# ----------------------------------------------------------------------------- found cases
def test_found_sampled_fit_with_one_shot_fails_before_spending():
    engine = SamplerEngine(seed=0)
    with pytest.raises(ValueError, match=r"shots must be an int >= 2 .*\(a sampled gradient"):
        QNNClassifier(engine=engine, shots=1, verbose=False).fit(XS, YS)
    assert engine.ledger.total_shots == 0 and engine.ledger.entries == []


def test_found_ledger_refuses_negative_and_fractional_counts():
    ledger = ShotLedger()
    with pytest.raises(ValueError, match="circuits must be >= 0, got -1"):
        ledger.record("x", -1, -5)
    with pytest.raises(TypeError, match="shots must be an int, got 2.5"):
        ledger.record("x", 1, 2.5)
    assert ledger.total_shots == 0


def test_found_seed_minus_one_is_refused_by_name_everywhere():
    calls = [lambda: DensityQNN([round_robin(N)], seed=-1), lambda: SamplerEngine(seed=-1),
             lambda: QNNRegressor(seed=-1, epochs=1, verbose=False).fit(XS, XS[:, 0]),
             lambda: Linear(2, 2, seed=-1), lambda: load_digits_features(4, 100, -1),
             lambda: OBSERVED.sample(X1, 10, seed=-1), lambda: bootstrap_ci([1.0, 2.0], seed=-1)]
    for call in calls:
        with pytest.raises(ValueError, match=r"seed must be an int >= 0.*got -1"):
            call()


def test_found_targets_near_1e200_are_refused_with_a_scaling_hint():
    with pytest.raises(ValueError, match="y is too large.*TransformedTargetRegressor"):
        QNNRegressor(epochs=1, verbose=False).fit(XS, np.full(12, 1e200))
    with pytest.raises(ValueError, match="X is too large.*StandardScaler"):
        QNNRegressor(epochs=1, verbose=False).fit(np.full((12, 3), 1e200), XS[:, 0])
