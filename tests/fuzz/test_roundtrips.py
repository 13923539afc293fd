"""Every public class survives ``pickle``, ``copy.deepcopy`` and ``sklearn.base.clone`` in every
state (fresh, used, fitted) with equal behaviour after the round trip; and scikit-learn's
workflows (``clone`` + ``cross_val_score``) run 500 rounds without a crash.

The classes are read off every public module's ``__all__`` (each package of ``qdensity``, every
module whose path has no private part, the optional torch layer): a class with no entry in
:data:`RECIPES` fails :func:`test_every_public_class_has_a_recipe`, so a new class gets one. A
recipe builds the class's objects in their states and names a behaviour: a function of the
object whose value (arrays, numbers, circuits, nested containers) must be the same for the
object and for its copy. Behaviours read the objects through their public methods and
attributes only.
"""

from __future__ import annotations

import copy
import dataclasses
import importlib
import inspect
import pickle
import pkgutil

import numpy as np
import pytest
from qiskit import QuantumCircuit
from sklearn.base import BaseEstimator, clone

import qdensity
from qdensity.circuits.ansatze import pyramid, round_robin
from qdensity.models import DensityQNN, Encoding
from qdensity.models.decompositions import by_moments
from qdensity.models.mixtures import FixedMixture, GatedMixture, SoftmaxMixture

try:  # the optional torch extra
    import torch
except ImportError:  # pragma: no cover - CI installs it
    torch = None


def public_classes() -> dict[str, type]:
    """``"module.qualname" -> class`` for every class in a public module's ``__all__``."""
    names = ["qdensity"] + sorted(
        m.name for m in pkgutil.walk_packages(qdensity.__path__, "qdensity.")
        if not any(part.startswith("_") for part in m.name.split(".")[1:]))
    out: dict[str, type] = {}
    for name in names:
        try:
            module = importlib.import_module(name)
        except ImportError:  # an optional extra (torch) not installed
            continue
        for attr in getattr(module, "__all__", ()):
            obj = getattr(module, attr, None)
            if inspect.isclass(obj):
                out.setdefault(f"{obj.__module__}.{obj.__qualname__}", obj)
    return dict(sorted(out.items()))


# ------------------------------------------------------------------ comparing behaviour
def same(a, b, path="value") -> None:
    """Assert ``a`` and ``b`` are equal values (arrays exactly, floats bit for bit)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b), err_msg=path)
        assert np.asarray(a).dtype == np.asarray(b).dtype, path
    elif torch is not None and isinstance(a, torch.Tensor):
        assert torch.equal(a, b), path
    elif isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), path
        for k in a:
            same(a[k], b[k], f"{path}[{k!r}]")
    elif isinstance(a, (list, tuple)):
        assert type(a) is type(b) and len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            same(x, y, f"{path}[{i}]")
    elif isinstance(a, QuantumCircuit):
        assert isinstance(b, QuantumCircuit) and a == b, path
    elif dataclasses.is_dataclass(a) and not isinstance(a, type):
        assert type(a) is type(b), path
        for f in dataclasses.fields(a):
            same(getattr(a, f.name), getattr(b, f.name), f"{path}.{f.name}")
    elif isinstance(a, float) and np.isnan(a):
        assert isinstance(b, float) and np.isnan(b), path
    else:
        assert a == b, f"{path}: {a!r} != {b!r}"


def fields(obj):
    """The behaviour of a value object: its dataclass fields, compared one by one."""
    return {f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)}


# ------------------------------------------------------------------ shared small objects
X4 = np.random.default_rng(0).normal(size=(3, 4))


def unary_model(mixture="softmax", readout="unary_probabilities", seed=0) -> DensityQNN:
    dec = by_moments(round_robin(4))
    K = dec.num_subunitaries
    mix = {"softmax": SoftmaxMixture(K), "fixed": FixedMixture(np.full(K, 1 / K)),
           "gated": GatedMixture(4, K, seed=seed + 1)}[mixture]
    return DensityQNN(dec.sub_unitaries, mix, encoding=Encoding.unary(4), readout=readout,
                      seed=seed)


def used_model(model):
    model.predict(X4)  # fills any caches (compiled circuits, engines)
    return model


def tiny_model() -> DensityQNN:
    """Two sub-unitaries of one RBS each on two qubits: plans of a few circuits."""
    return DensityQNN([pyramid(2, parameter_prefix="a"), pyramid(2, parameter_prefix="b")],
                      SoftmaxMixture(2), encoding=Encoding.unary(2),
                      readout="unary_probabilities", seed=0)


X2 = np.array([[0.6, 0.8]])


def _run_exact(engine):
    """Run a small plan on ``engine`` and return what it answered (its behaviour)."""
    from qdensity.gradients.density import density_gradient_plan

    res = density_gradient_plan(tiny_model(), X2).run(engine)
    return (res.outputs, res.jacobians)


def _sampled(engine):
    from qdensity.gradients.density import density_gradient_plan

    res = density_gradient_plan(tiny_model(), X2, shots=64).run(engine)
    return (res.outputs, res.jacobians)


# ------------------------------------------------------------------ recipes
# Each recipe returns [(state, object, behaviour)] where behaviour(obj) is compared between
# the object and its copy. A behaviour that draws random numbers is called on both only after
# the copy, from the same state, so equal seeds give equal draws.


def _constraints():
    from qdensity import validation as v

    probes = [1, 2.5, -1, "a", None, np.zeros(2), np.zeros((2, 2)), [1, 2], QuantumCircuit(2),
              lambda: 0, True]

    def behaviour(c):
        return (str(c), [bool(c.is_satisfied_by(p)) for p in probes])

    made = {"Constraint": None, "Instance": v.Instance((int, "numpy:ndarray")),
            "Interval": v.Interval(int, 0, 5), "Options": v.Options(("a", "b")),
            "Unchecked": v.Unchecked("checked in the body", 1), "Array": v.Array(ndim=1),
            "CallableC": v.CallableC(), "Circuit": v.Circuit(1, 4),
            "EngineLike": v.EngineLike(), "FilePath": v.FilePath(None),
            "Observable": v.Observable(), "Seed": v.Seed(), "SequenceOf": v.SequenceOf(int),
            "TargetLike": v.TargetLike(), "TorchTensor": v.TorchTensor(1)}
    out = {}
    for name, c in made.items():
        if c is None:
            out[name] = lambda: [("fresh", v.Constraint(), lambda k: type(k).__name__)]
            continue

        def recipe(c=c):
            fresh = copy.deepcopy(c)
            behaviour(c)  # used: lazy types loaded
            return [("fresh", fresh, behaviour), ("used", c, behaviour)]

        out[name] = recipe
    return out


def _gates():
    from qdensity.circuits.gates import FBSGate, RBSGate

    return {"RBSGate": lambda: [("fresh", RBSGate(0.3), lambda g: g.to_matrix())],
            "FBSGate": lambda: [("fresh", FBSGate(0.3, 4), lambda g: g.to_matrix())]}


def _preparation():
    from qdensity.circuits.preparation import PreparationCircuits

    def recipe():
        prep = PreparationCircuits([pyramid(3, parameter_prefix="a"),
                                    pyramid(3, parameter_prefix="b")], np.array([0.25, 0.75]))
        fresh = copy.deepcopy(prep)
        prep.prepare_all()
        return [("fresh", fresh, lambda p: p.prepare_all()),
                ("used", prep, lambda p: p.prepare_all())]

    return {"PreparationCircuits": recipe}


def _tomography():
    from qdensity.circuits.tomography import reconstruct

    counts = [{"0001": 60, "0010": 40}, {"0011": 50, "0001": 30, "0010": 20},
              {"0001": 60, "0010": 40}]
    return {"TomographyResult": lambda: [("fitted", reconstruct(counts, 4), fields)]}


def _engines():
    from qdensity.execution.exact import ExactEngine
    from qdensity.execution.statevector.adjoint import AdjointEngine

    def exact():
        fresh, used = ExactEngine(), ExactEngine()
        _run_exact(used)
        return [("fresh", fresh, _run_exact), ("used", used, _run_exact)]

    def adjoint():
        fresh, used = AdjointEngine(), AdjointEngine()
        m = unary_model()
        from qdensity.models.exact import exact_gradients

        exact_gradients(m, X4, used)

        def behaviour(e):
            r = exact_gradients(unary_model(), X4, e)
            return (r.outputs, r.jacobians)

        return [("fresh", fresh, behaviour), ("used", used, behaviour)]

    return {"ExactEngine": exact, "AdjointEngine": adjoint}


def _plans():
    from qdensity.execution.exact import ExactEngine
    from qdensity.gradients.density import density_gradient_plan

    def plan():
        p = density_gradient_plan(tiny_model(), X2)

        engine = ExactEngine()  # one engine for every run: the plan is what is copied

        def behaviour(q):
            r = q.run(engine)
            return (q.num_circuits, r.outputs, r.jacobians)

        fresh = copy.deepcopy(p)
        behaviour(p)
        return [("fresh", fresh, behaviour), ("used", p, behaviour)]

    def job():
        p = density_gradient_plan(tiny_model(), X2)
        j = p.jobs[0]
        return [("fresh", j, lambda j: (j.circuit, j.values, j.shots, j.label))]

    def estimate():
        from qdensity.execution.plans import Estimate

        return [("fresh", Estimate(np.ones(2), np.zeros(2)), fields)]

    def job_result():
        from qdensity.execution.job_results import JobResult

        r = JobResult(probabilities=np.array([[0.25, 0.75]]), shots=None)
        return [("fresh", r, lambda r: (r.probabilities, r.shots))]

    return {"Plan": plan, "CircuitJob": job, "Estimate": estimate, "JobResult": job_result}


def _sampler_side():
    from qdensity.execution.sampler.engine import LedgerEntry, SamplerEngine, ShotLedger
    from qdensity.execution.samplers import HammingWeightSampler

    def engine():
        fresh, used = SamplerEngine(seed=0), SamplerEngine(seed=0)
        _sampled(used)
        return [("fresh", fresh, _sampled), ("used", used, _sampled)]

    def hamming():
        fresh = HammingWeightSampler(seed=1)
        used = HammingWeightSampler(seed=1)
        kept = _hw_circuit()  # alive while the recipe's objects are: its template stays cached
        used.run([(kept[0], kept[1], 32)]).result()

        def behaviour(s, kept=kept):
            return _hw_counts(s)

        return [("fresh", fresh, behaviour), ("used", used, behaviour)]

    def ledger():
        led = ShotLedger()
        led.entries.append(LedgerEntry("a", 2, 128, "aer"))
        return [("used", led, lambda x: (x.entries, x.total_shots))]

    return {"SamplerEngine": engine, "HammingWeightSampler": hamming, "ShotLedger": ledger,
            "LedgerEntry": lambda: [("fresh", LedgerEntry("a", 2, 128, "aer"), fields)]}


def _values():
    from qdensity.analysis.pauli import ZStringTable
    from qdensity.cli.plugins import command_texts
    from qdensity.demo import DemoConfig
    from qdensity.execution.sampler.mitigated import MitigatedEstimate
    from qdensity.gradients.shift import ShiftRule
    from qdensity.learning.estimators import UnscaledFeaturesWarning
    from qdensity.learning.layer import BudgetExhausted, History

    def history():
        h = History()
        h.append(loss=0.5, shots=10)
        h.append(loss=0.25, shots=20)
        return [("fresh", History(), lambda h: len(h)),
                ("used", h, lambda h: (len(h), h["loss"], h.records, h.epochs))]

    def exc(e):
        return (type(e).__name__, e.args, str(e))

    def unsupported():
        from qdensity.execution.samplers.hamming import UnsupportedInstructionError

        return [("fresh", UnsupportedInstructionError("cannot sample 'h'"), exc)]

    return {
        "ZStringTable": lambda: [("fresh", ZStringTable(np.array([[1, 0], [0, 1]], dtype=bool),
                                                        np.array([0.5, -1.0])),
                                  lambda t: (t.z, t.coefficients))],
        "CommandTexts": lambda: [("fresh", command_texts("does a thing", "qdensity x"),
                                  lambda t: tuple(t))],
        "DemoConfig": lambda: [("fresh", DemoConfig(), fields)],
        "MitigatedEstimate": lambda: [("fresh", MitigatedEstimate(
            np.ones(2), np.zeros(2), np.ones(2), np.ones(2), 100), fields)],
        "ShiftRule": lambda: [("fresh", ShiftRule((np.pi / 2, -np.pi / 2), (0.5, -0.5)),
                               fields)],
        "History": history,
        "BudgetExhausted": lambda: [("fresh", BudgetExhausted("budget spent"), exc)],
        "UnscaledFeaturesWarning": lambda: [("fresh", UnscaledFeaturesWarning("scale"), exc)],
        "UnsupportedInstructionError": unsupported,
    }


def _schedulers():
    from qdensity.execution.schedulers import (
        NeymanScheduler,
        PerShotScheduler,
        ProportionalScheduler,
    )
    from qdensity.execution.schedulers.sources import discrete_source

    def run(s):
        src = discrete_source(np.array([[0.2, 0.8], [0.6, 0.4]]), np.array([-1.0, 1.0]), seed=3)
        return fields(s.run(np.array([0.3, 0.7]), 200, src, seed=4))

    def recipe(cls):
        def make():
            used = cls()
            run(used)
            return [("fresh", cls(), run), ("used", used, run)]
        return make

    def result():
        src = discrete_source(np.array([[0.2, 0.8], [0.6, 0.4]]), np.array([-1.0, 1.0]), seed=3)
        return [("fitted", PerShotScheduler().run(np.array([0.3, 0.7]), 100, src, seed=1),
                 fields)]

    # Scheduler is a typing.Protocol (never constructed): an implementation stands in for it
    return {"NeymanScheduler": recipe(NeymanScheduler),
            "PerShotScheduler": recipe(PerShotScheduler),
            "ProportionalScheduler": recipe(ProportionalScheduler),
            "ScheduleResult": result,
            "Scheduler": recipe(ProportionalScheduler)}


def _gradients():
    from qiskit.quantum_info import SparsePauliOp

    from qdensity.circuits.ansatze import hardware_efficient
    from qdensity.execution.exact import ExactEngine
    from qdensity.gradients.blocks import commuting_block_gradient
    from qdensity.gradients.commuting import commuting_gradient
    from qdensity.gradients.density import density_gradient_plan

    def circuit_values(g):
        return (g.circuits, [str(p) for p in g.parameters])

    def commuting():
        from qdensity.circuits.ansatze import equivariant

        circ = equivariant.xx_commuting(3) if hasattr(equivariant, "xx_commuting") else None
        if circ is None:
            from qiskit.circuit import ParameterVector

            t = ParameterVector("t", 2)
            circ = QuantumCircuit(2)
            circ.rzz(t[0], 0, 1)
            circ.rz(t[1], 0)
        g = commuting_gradient(circ, SparsePauliOp("ZI"))
        return [("fresh", g, circuit_values)]

    def block():
        circ = hardware_efficient(2, 1)
        g = commuting_block_gradient(circ, SparsePauliOp("ZI"))
        return [("fresh", g, circuit_values)]

    def density():
        res = density_gradient_plan(tiny_model(), X2).run(ExactEngine())
        return [("fitted", res, fields)]

    return {"CommutingGradient": commuting, "CommutingBlockGradient": block,
            "DensityGradient": density}


def _unary_circuit():
    from qdensity.execution.unary import compile_unary, forward

    def behaviour(c):
        return forward(c, X4, np.linspace(0, 1, c.num_parameters))

    def recipe():
        used = compile_unary(round_robin(4))
        behaviour(used)
        return [("fresh", compile_unary(round_robin(4)), behaviour), ("used", used, behaviour)]

    return {"UnaryCircuit": recipe}


def _hardware():
    from qdensity.execution.samplers.aer import AdaptiveSampler, AerSampler, NoiselessSimulators
    from qdensity.hardware.mitigation import ReadoutMitigator
    from qdensity.hardware.resources import resource_report
    from qdensity.hardware.snapshot_files import load_snapshot, save_snapshot
    from qdensity.hardware.targets import get_target

    def target():
        t = get_target("line", 4) if "line" in _target_names() else get_target(
            _target_names()[0], 4)
        return [("fresh", t, lambda t: (t.name, t.num_qubits, t.basis_gates))]

    def report():
        return [("fitted", resource_report(round_robin(4)), fields)]

    def snapshot():
        import tempfile
        from pathlib import Path

        from qiskit.providers.fake_provider import GenericBackendV2

        with tempfile.TemporaryDirectory() as d:  # the backend is read whole, then deleted
            b = load_snapshot(save_snapshot(GenericBackendV2(3, seed=1), Path(d) / "snap.json"))
        return [("fresh", b, lambda b: (b.name, b.num_qubits, sorted(b.operation_names)))]

    def mitigator():

        fresh = ReadoutMitigator(get_target("line", 2), shots=200, seed=0)
        used = ReadoutMitigator(get_target("line", 2), shots=200, seed=0)
        used.calibrate([0, 1])

        def behaviour(m):
            if not m.calibrated_qubits:
                return m.calibrated_qubits
            return (m.calibrated_qubits, m.readout_matrices([0, 1]))

        return [("fresh", fresh, behaviour), ("used", used, behaviour)]

    def sample(s):
        from qiskit.circuit import Parameter

        t = Parameter("t")
        circ = QuantumCircuit(2)
        circ.ry(t, 0)
        circ.cx(0, 1)
        circ.measure_all()
        res = s.run([(circ, np.array([[0.3], [1.2]]), 32)]).result()[0]
        return res.data.meas.get_counts()

    def aer():
        from qiskit_aer import AerSimulator

        used = AerSampler(AerSimulator(), seed=2)
        sample(used)
        return [("fresh", AerSampler(AerSimulator(), seed=2), sample), ("used", used, sample)]

    def adaptive():

        def make():
            return AdaptiveSampler(_simulator, False, seed=2)

        used = make()
        sample(used)
        return [("fresh", make(), sample), ("used", used, sample)]

    def noiseless():
        return [("fresh", NoiselessSimulators(seed=1), lambda n: type(n).__name__)]

    return {"HardwareTarget": target, "ResourceReport": report,
            "SnapshotFileBackend": snapshot, "ReadoutMitigator": mitigator,
            "AerSampler": aer, "AdaptiveSampler": adaptive,
            "NoiselessSimulators": noiseless}


def _simulator(method):
    from qiskit_aer import AerSimulator

    return AerSimulator(method=method)


def _noisy_simulator(noise_model, method):
    from qiskit_aer import AerSimulator

    return AerSimulator(method=method, noise_model=noise_model)


def _hw_circuit():
    """A Hamming-weight-1 circuit (X on qubit 0, then RBS gates), measured, and two rows."""
    circ = QuantumCircuit(4)
    circ.x(0)
    circ.compose(round_robin(4), inplace=True)
    circ.measure_all()
    return circ, np.linspace(0, 1, 2 * circ.num_parameters).reshape(2, -1)


def _hw_counts(sampler):
    circ, vals = _hw_circuit()
    res = sampler.run([(circ, vals, 32)]).result()[0]
    return res.data.meas.get_counts()


def _target_names():
    from qdensity.hardware.targets import known_targets

    return list(known_targets())


def _deferred():
    from qdensity.execution.samplers import HammingWeightSampler

    def recipe():
        circ, vals = _hw_circuit()
        (d,) = HammingWeightSampler(seed=5).defer([(circ, vals, 16)])
        return [("fresh", d, lambda d: (d.shape, d.num_shots, d.packed()))]

    return {"DeferredSamples": recipe}


def _models():
    from qdensity.models.dropout import QuantumDropout
    from qdensity.models.exact import engines_of, exact_gradients, input_columns
    from qdensity.models.lcu import LCUQNN
    from qdensity.models.single_qubit import SingleQubitReuploading

    def predict(m):
        return m.predict(X4)

    def density():
        out = []
        for mix in ("softmax", "fixed", "gated"):
            out += [("fresh", unary_model(mix), predict),
                    ("used", used_model(unary_model(mix)), predict)]
        return out

    def mixture(kind):
        def alpha(m):
            return m.alpha(X4)

        def make():
            m = unary_model(kind)
            fresh = copy.deepcopy(m.mixture)
            used_model(m)
            return [("fresh", fresh, alpha), ("used", m.mixture, alpha)]
        return make

    def decomposition():
        return [("fresh", by_moments(round_robin(4)),
                 lambda d: (d.name, d.sub_unitaries, d.independent))]

    def encoding():
        e = Encoding.unary(4)
        return [("fresh", e, lambda e: (e.circuit, e.transform(X4), e.num_features, e.kind))]

    def lcu():
        fresh = LCUQNN([pyramid(3, parameter_prefix="a"), pyramid(3, parameter_prefix="b")],
                       seed=0)
        used = copy.deepcopy(fresh)
        x = np.array([[0.6, 0.8, 0.0]])
        used.sample(x, 16, seed=1)

        def behaviour(m):
            return m.sample(x, 64, seed=3)

        return [("fresh", fresh, behaviour), ("used", used, behaviour)]

    def postselected():
        m = LCUQNN([pyramid(3, parameter_prefix="a"), pyramid(3, parameter_prefix="b")], seed=0)
        return [("fitted", m.sample(np.array([[0.6, 0.8, 0.0]]), 64, seed=3), fields)]

    def reuploading():
        m = SingleQubitReuploading(2, 2, seed=0)
        used = copy.deepcopy(m)
        x = np.linspace(-1, 1, 5)[:, None]
        used.predict(x)
        return [("fresh", m, lambda m: m.predict(x)), ("used", used, lambda m: m.predict(x))]

    def dropout():
        x = np.linspace(-1, 1, 5)[:, None]
        d = QuantumDropout(SingleQubitReuploading(2, 2, seed=0), shots=16)
        used = copy.deepcopy(d)
        used.predict(x, seed=1)
        return [("fresh", d, lambda d: d.predict(x, seed=2)),
                ("used", used, lambda d: d.predict(x, seed=2))]

    def exact_results():
        return [("fitted", exact_gradients(unary_model(), X4), fields)]

    def columns():
        m = unary_model()
        return [("fitted", input_columns(m, m.circuit(0)), fields)]

    def engines():
        m = used_model(unary_model())
        return [("fitted", engines_of(m), lambda e: e.circuits)]

    return {"DensityQNN": density, "SoftmaxMixture": mixture("softmax"),
            "FixedMixture": mixture("fixed"), "GatedMixture": mixture("gated"),
            "Mixture": mixture("softmax"),  # abstract: a subclass stands in
            "Decomposition": decomposition,
            "Encoding": encoding, "LCUQNN": lcu, "PostselectedUnary": postselected,
            "SingleQubitReuploading": reuploading, "QuantumDropout": dropout,
            "ExactGradients": exact_results, "InputColumns": columns,
            "ModelEngines": engines}


def _learning():
    from qdensity.learning.estimators import QNNClassifier, QNNRegressor
    from qdensity.learning.layer import QuantumLayer
    from qdensity.learning.nn import Linear
    from qdensity.learning.optim import SGD, Adam, RMSprop

    Xc = np.abs(X4) + 0.1
    yc = np.array([0, 1, 0])

    def estimator(cls, y):
        def fit_predict(e):
            return copy.deepcopy(e).fit(Xc, y).predict(Xc)

        def make():
            fresh = cls(epochs=1, verbose=False, seed=0)
            fitted = cls(epochs=1, verbose=False, seed=0).fit(Xc, y)
            return [("fresh", fresh, fit_predict), ("fitted", fitted, lambda e: e.predict(Xc))]
        return make

    def layer():
        def behaviour(q):
            return q.forward(X4[:, :4] / np.linalg.norm(X4, axis=1, keepdims=True))

        used = QuantumLayer(unary_model())
        used.forward(np.abs(X4))
        used.backward(np.ones((3, 4)))
        return [("fresh", QuantumLayer(unary_model()), behaviour), ("used", used, behaviour)]

    def linear():
        def behaviour(l):
            return l.forward(X4)

        used = Linear(4, 2, seed=0)
        used.forward(X4)
        used.backward(np.ones((3, 2)))
        return [("fresh", Linear(4, 2, seed=0), behaviour), ("used", used, behaviour)]

    def optimizer(cls, **kw):
        def behaviour(o):
            o = copy.deepcopy(o)
            return o.step(np.ones(3), np.array([0.1, -0.2, 0.3]))

        def make():
            used = cls(**kw)
            used.step(np.ones(3), np.array([0.5, 0.5, 0.5]))
            return [("fresh", cls(**kw), behaviour), ("used", used, behaviour)]
        return make

    return {"QNNClassifier": estimator(QNNClassifier, yc),
            "QNNRegressor": estimator(QNNRegressor, np.array([0.1, 0.5, 0.9])),
            "QuantumLayer": layer, "Linear": linear,
            "Layer": linear,  # abstract: a subclass stands in
            "Adam": optimizer(Adam, lr=0.1), "SGD": optimizer(SGD, lr=0.1, momentum=0.9),
            "RMSprop": optimizer(RMSprop, lr=0.1),
            "Optimizer": optimizer(SGD, lr=0.1)}  # abstract: a subclass stands in


def _torch_layer():
    if torch is None:  # pragma: no cover - CI installs the extra
        return {}
    from qdensity.learning.torch import DensityQNNLayer, MoEGate

    x = torch.tensor(np.abs(X4) + 0.1)

    def forward(m):
        with torch.no_grad():
            return m(x)

    def layer():
        out = []
        for engine in ("exact", "torch"):
            fresh = DensityQNNLayer(unary_model("gated"), engine=engine)
            used = DensityQNNLayer(unary_model("gated"), engine=engine)
            used(x).sum().backward()
            out += [("fresh", fresh, forward), ("used", used, forward)]
        return out

    def gate():
        g = MoEGate(4, 3, "gelu")
        return [("fresh", g, forward)]

    return {"DensityQNNLayer": layer, "MoEGate": gate}


def _registries():
    """Registered entries load as the registry's own entry; an unregistered one copies by
    value."""
    from qdensity.analysis.gate_registry import GATES, GateKind
    from qdensity.circuits.ansatze.registry import FAMILIES, AnsatzFamily
    from qdensity.models.registry import DECOMPOSITIONS, MIXTURES, DecompositionKind, MixtureKind

    def recipe(registry, name, unregistered, behaviour):
        def make():
            return [("fresh", registry[name], behaviour), ("fresh", unregistered, behaviour)]
        return make

    return {
        "GateKind": recipe(GATES, "rbs", GateKind("my_gate", real=True),
                           lambda g: (g.name, g.real, g.preserves_hamming_weight,
                                      None if g.matrix is None else g.matrix([0.3]))),
        "AnsatzFamily": recipe(FAMILIES, "pyramid", AnsatzFamily("mine", pyramid),
                               lambda f: (f.name, _unitary(f.builder(4)), f.parameter_count(4))),
        "DecompositionKind": recipe(DECOMPOSITIONS, "none",
                                    DecompositionKind("mine", _whole_circuit),
                                    lambda d: (d.name, [_unitary(c) for c in
                                                        d.split(round_robin(4), 2)])),
        "MixtureKind": recipe(MIXTURES, "softmax", MixtureKind("mine", _no_mixture),
                              lambda m: (m.name, m.data_dependent,
                                         type(m.build(4, 3, 0)).__name__)),
    }


def _unitary(circuit):
    """The matrix of ``circuit`` at fixed angles (two builds differ in their parameters' ids,
    not in what they do)."""
    from qiskit.quantum_info import Operator

    bound = circuit.assign_parameters(np.linspace(0.1, 0.9, circuit.num_parameters))
    return Operator(bound).data


def _whole_circuit(circuit, depth):
    return [circuit]


def _no_mixture(num_qubits, k, seed):
    return None


def _sampler_states():
    """States of non-sampler classes that hold a sampler engine (the issue's fitted
    ``QNNClassifier(engine=SamplerEngine(seed=0), shots=64)``)."""
    from qdensity.execution.sampler.engine import SamplerEngine
    from qdensity.learning.estimators import QNNClassifier

    Xc, yc = np.abs(X4) + 0.1, np.array([0, 1, 0])

    def estimator():
        def make():
            return QNNClassifier(engine=SamplerEngine(seed=0), shots=64, epochs=1,
                                 verbose=False, seed=0)

        def fit_predict(e):
            return copy.deepcopy(e).fit(Xc, yc).predict_proba(Xc)

        return [("fresh", make(), fit_predict),
                ("fitted", make().fit(Xc, yc), lambda e: e.predict_proba(Xc))]

    out = {"QNNClassifier[SamplerEngine]": estimator}
    if torch is not None:
        from qdensity.learning.torch import DensityQNNLayer

        def layer():
            x = torch.tensor(Xc)
            used = DensityQNNLayer(unary_model(), engine=SamplerEngine(seed=0), shots=64)
            used(x).sum().backward()

            def forward(m):
                with torch.no_grad():
                    return m(x)

            return [("used", used, forward)]

        out["DensityQNNLayer[SamplerEngine]"] = layer
    return out

def _late_additions():
    """Classes added with the exact noisy sampler, dropout, file names and qiskit-ml."""
    from qiskit.providers.fake_provider import GenericBackendV2
    from qiskit_aer.noise import NoiseModel

    from qdensity import validation as v
    from qdensity.execution.sampler.engine import ShotLedger
    from qdensity.execution.samplers.noisy_exact import ExactNoisySampler, ExactRoute, NoiseTables
    from qdensity.models.dropout import RandomisedPreparation

    def noise():
        return NoiseModel.from_backend(GenericBackendV2(2, seed=3))

    def noisy_circuit():
        circ = QuantumCircuit(2, name="bell-ish")  # the draws' stream reads the name
        circ.x(0)
        circ.cx(0, 1)
        circ.measure_all()
        return circ

    def file_name():
        c = v.FileName()
        probes = ["a.json", "../x", "a/b", "", "ok-name.png", 3]
        return [("fresh", c, lambda c: (str(c), [bool(c.is_satisfied_by(p)) for p in probes]))]

    def exact_sampler():
        def counts(s):
            return s.run([(noisy_circuit(), None, 64)]).result()[0].data.meas.get_counts()

        used = ExactNoisySampler(noise(), seed=4)
        counts(used)
        return [("fresh", ExactNoisySampler(noise(), seed=4), counts), ("used", used, counts)]

    def tables():
        return [("fresh", NoiseTables(noise()), lambda t: t.ok)]

    def route():
        def taken(r):
            from qiskit.primitives.containers import SamplerPub

            out: list = [None]
            chosen = r.take([SamplerPub.coerce((noisy_circuit(), None, 4096))], out, 5, {})
            return (sorted(chosen), out[0].data.meas.get_counts() if chosen else None)

        def make():
            import functools

            return ExactRoute(functools.partial(_noisy_simulator, noise()), True)

        used = make()
        taken(used)
        return [("fresh", make(), taken), ("used", used, taken)]

    def preparation():
        alpha = np.array([[0.3, 0.7], [0.5, 0.5]])
        probs = np.array([[[0.2, 0.8], [0.6, 0.4]], [[0.5, 0.5], [0.9, 0.1]]])
        values = np.array([[1.0], [-1.0]])

        def make():
            return RandomisedPreparation(alpha, probs, values, 16, seed=2, ledger=ShotLedger())

        used = make()
        used.outputs()
        return [("fresh", make(), lambda r: r.outputs()), ("used", used, lambda r: r.outputs())]

    def qiskit_ml():
        from qiskit.circuit import Parameter

        from qdensity.circuits.gates import RBSGate
        from qdensity.execution.samplers import HammingWeightSampler
        from qdensity.gradients.qiskit_ml import HammingShiftSamplerGradient

        theta = Parameter("t")
        circ = QuantumCircuit(2)
        circ.x(0)
        circ.append(RBSGate(theta), [0, 1])
        circ.measure_all()

        def grad(g):
            res = g.run([circ], [[0.4]]).result()
            return [sorted(d.items()) for d in res.gradients[0]]

        def make():
            return HammingShiftSamplerGradient(HammingWeightSampler(seed=6))

        used = make()
        grad(used)
        return [("fresh", make(), grad), ("used", used, grad)]

    return {"FileName": file_name, "ExactNoisySampler": exact_sampler, "NoiseTables": tables,
            "ExactRoute": route, "RandomisedPreparation": preparation,
            "HammingShiftSamplerGradient": qiskit_ml}



#: Recipes of the states above (run beside the classes' own recipes).
SAMPLER_STATES = ("QNNClassifier[SamplerEngine]", "DensityQNNLayer[SamplerEngine]")

RECIPES: dict = {}
for _group in (_constraints, _gates, _preparation, _tomography, _engines, _plans,
               _sampler_side, _values, _schedulers, _gradients, _unary_circuit, _hardware,
               _deferred, _models, _learning, _torch_layer, _registries, _sampler_states,
               _late_additions):
    RECIPES.update(_group())


# ------------------------------------------------------------------ the tests
def _short(name: str) -> str:
    return name.rsplit(".", 1)[-1]


def test_every_public_class_has_a_recipe():
    missing = sorted(n for n in public_classes() if _short(n) not in RECIPES)
    assert not missing, f"public classes without a round-trip recipe in {__file__}: {missing}"


def _cases():
    for name in public_classes():
        short = _short(name)
        if short in RECIPES:
            yield pytest.param(short, id=short)
    for name in SAMPLER_STATES:
        if name in RECIPES:
            yield pytest.param(name, id=name)


@pytest.mark.parametrize("short", list(_cases()))
def test_round_trips_keep_behaviour(short):
    cases = RECIPES[short]()
    fresh = cases[0][1]
    for state, obj, behaviour in cases:
        for how in ("pickle", "deepcopy", "clone"):
            twin = _copy(obj, how)
            assert type(twin) is type(obj), (short, state, how)
            if how == "clone" and isinstance(obj, BaseEstimator):
                # an unfitted copy with the same hyperparameters: it fits as the fresh one does
                fit = cases[0][2]
                same(fit(copy.deepcopy(fresh)), fit(twin), f"{short} {state} {how}")
                continue
            # the original first, then the copy: both from the same state
            same(behaviour(obj), behaviour(twin), f"{short} {state} {how}")


def _copy(obj, how: str):
    if how == "pickle":
        return pickle.loads(pickle.dumps(obj))
    if how == "deepcopy":
        return copy.deepcopy(obj)
    if isinstance(obj, BaseEstimator):
        return clone(obj)  # unfitted, same hyperparameters
    return clone(obj, safe=False)  # scikit-learn deep-copies what is not an estimator


def test_clone_and_cross_val_score_500_rounds_without_a_crash():
    """scikit-learn's workflows clone (deep-copy) estimators again and again: 500 clones of a
    fitted QNNClassifier whose model template has been used (its caches filled), each clone
    refitted by ``cross_val_score`` every 50th round; no round may crash, and every clone has
    the template's hyperparameters and refits to the same scores (seeded)."""
    from sklearn.model_selection import cross_val_score

    from qdensity.learning.estimators import QNNClassifier

    rng = np.random.default_rng(0)
    X, y = np.abs(rng.normal(size=(8, 4))) + 0.1, np.array([0, 1] * 4)
    template = used_model(unary_model())
    est = QNNClassifier(template, epochs=1, batch_size=8, verbose=False, seed=0).fit(X, y)
    first = None
    for i in range(500):
        twin = clone(est)
        assert twin.get_params(deep=False).keys() == est.get_params(deep=False).keys()
        assert twin.model is not template and not hasattr(twin, "layer_")
        same(twin.model.get_params(), template.get_params(), f"round {i}")
        if i % 50 == 0:
            same(twin.model.predict(X), template.predict(X), f"round {i}")
            scores = cross_val_score(twin, X, y, cv=2)
            first = scores if first is None else first
            same(scores, first, f"round {i}")


@pytest.mark.parametrize("short", ["AdjointEngine", "ExactEngine", "PreparationCircuits",
                                   "LCUQNN", "DensityQNN"])
def test_caches_are_rebuilt_not_pickled(short):
    """A used engine or model pickles to the size of a fresh one (compiled programs, transpiled
    templates, prepared circuits are rebuilt on use, never carried); its copy still behaves the
    same (the round-trip test)."""
    cases = RECIPES[short]()
    fresh = [obj for state, obj, _ in cases if state == "fresh"]
    used = [obj for state, obj, _ in cases if state == "used"]
    for f, u in zip(fresh, used, strict=True):
        assert len(pickle.dumps(u)) <= len(pickle.dumps(f)) + 256, short
