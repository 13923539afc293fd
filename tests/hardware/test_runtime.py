"""A provider's runtime client (qiskit-ibm-runtime, local testing mode) behind SamplerEngine.

Needs the ``ibm`` extra (CI installs it). Oracles: exact gradients and expectations (the
runtime sampler with an ideal noise model must agree within a few standard errors), the shots
in the PUBs the sampler was handed (the ledger must equal them), and the device's own limits.
"""


import numpy as np
import pytest
from _noisy import expected_estimate
from _stats import stat_seed as _stat_seed
from qiskit import QuantumCircuit
from qiskit.quantum_info import SparsePauliOp, Statevector
from qiskit.transpiler import generate_preset_pass_manager
from qiskit_aer.noise import NoiseModel
from qiskit_ibm_runtime import Batch
from qiskit_ibm_runtime.fake_provider import FakeManilaV2
from scipy.stats import norm

from qdensity.circuits.ansatze import pyramid, round_robin
from qdensity.circuits.loaders import unary_loader
from qdensity.circuits.tomography import reconstruct, tomography_circuits
from qdensity.execution.exact import ExactEngine
from qdensity.execution.plans import CircuitJob, expectation_plan
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.execution.sampler.runtime import runtime_engine
from qdensity.gradients.density import density_gradient_plan
from qdensity.hardware.runtime import runtime_options, runtime_sampler
from qdensity.models import DensityQNN, Encoding
from qdensity.models.decompositions import by_moments

IDEAL = {"simulator": {"noise_model": NoiseModel()}}


def _spy(engine):
    """Record the shots of every PUB handed to the engine's sampler."""
    asked = []
    run = engine.sampler.run

    def spy(pubs, **kw):
        for circ, vals, shots in pubs:
            rows = 1 if vals is None else np.asarray(vals).reshape(-1, circ.num_parameters).shape[0]
            asked.append(rows * shots)
        return run(pubs, **kw)

    engine.sampler.run = spy
    return asked



def _model(n=3, seed=1):
    dec = by_moments(round_robin(n))
    return DensityQNN(dec.sub_unitaries, [0.5, 0.3, 0.2], encoding=Encoding.unary(n),
                      readout="observable", seed=seed)


def test_density_gradient_plan_through_the_runtime_sampler():
    backend = FakeManilaV2()
    engine = runtime_engine(backend, seed=_stat_seed(11), options=IDEAL)
    assert type(engine.sampler).__module__.startswith("qiskit_ibm_runtime")
    asked = _spy(engine)
    model = _model()
    X = np.random.default_rng(3).normal(size=(2, 3))
    exact = density_gradient_plan(model, X, method="shift").run(ExactEngine())
    plan = density_gradient_plan(model, X, method="shift", shots=3000)
    sampled = plan.run(engine)
    # every entry (fewer than 100) within 5 of its standard errors, normal for 3000 shots
    # (the 1e-3 floor for entries whose shots all agree): false failure < 100 x 5.7e-7 = 1e-4
    assert sum(j.size for j in exact.jacobians) + exact.outputs.size < 100
    for je, js, se in zip(exact.jacobians, sampled.jacobians, sampled.jacobian_errors,
                          strict=True):
        assert np.all(np.abs(js - je) <= 5 * np.maximum(se, 1e-3))
    assert np.all(np.abs(sampled.outputs - exact.outputs)
                  <= 5 * np.maximum(sampled.output_errors, 1e-3))
    assert engine.ledger.total_shots == sum(asked) == plan.total_shots


def test_forward_tomography_and_randomised_sampling_in_one_batch():
    backend = FakeManilaV2()
    pm = generate_preset_pass_manager(optimization_level=1, backend=backend, seed_transpiler=2)
    with Batch(backend=backend) as batch:
        sampler = runtime_sampler(batch, seed=_stat_seed(5), options=IDEAL)
        engine = SamplerEngine(sampler=sampler, transpiler=pm.run)
        asked = _spy(engine)
        # forward: an expectation plan
        qc = pyramid(4)
        obs = SparsePauliOp(["ZIII", "IIXX"], [1.0, 0.5])
        rows = np.random.default_rng(1).uniform(-1, 1, (2, qc.num_parameters))
        est = expectation_plan(unary_loader([1, 2, 3, 4]).compose(qc), obs, rows,
                               shots=4000).run(engine)
        # two estimates within 5 standard errors: false failure 2 x 5.7e-7
        for r, row in enumerate(rows):
            state = Statevector(unary_loader([1, 2, 3, 4]).compose(qc).assign_parameters(row))
            want = float(np.real(state.expectation_value(obs)))
            assert abs(est.value[r] - want) <= 5 * est.standard_error[r] + 1e-3
        # tomography (Supp. F): three circuits, one job
        x = np.array([0.5, -0.3, 0.2, -0.6])
        circs = tomography_circuits(unary_loader(x))
        res = engine.run([CircuitJob(c, None, 4000, f"tomo{i}") for i, c in enumerate(circs)])
        counts = [np.rint(r.probabilities[0] * 4000) for r in res]
        counts = [{format(b, "04b"): c for b, c in enumerate(cs) if c} for cs in counts]
        tomo = reconstruct(counts, 4)
        want = x / np.linalg.norm(x)
        want = want * np.sign(want[np.argmax(np.abs(want))])  # largest amplitude positive
        # magnitudes sqrt(p) from 4000 shots have sd <= 1 / (2 sqrt 4000) = 0.008, so 0.08 is
        # 10 sd; the signs come from interference terms 2 |a_i a_j| >= 0.08 against the same
        # sd (a wrong sign would cost 2 |a_i| >= 0.44): false failure < 1e-6
        assert np.max(np.abs(tomo.amplitudes - want)) < 0.08
        # randomised density sampling (Fig. 1c)
        model = _model(seed=4)
        xs = np.array([0.3, -1.0, 0.8])
        out = model.train().sample(xs, 6000, scheduler="proportional", engine=engine,
                                   seed=_stat_seed(3))
        want = model.predict(xs[None, :])[0]
        assert abs(out.estimate - want) <= 5 * out.standard_error  # false failure 5.7e-7
        assert batch.backend() is not None
    assert engine.ledger.total_shots == sum(asked)


def test_runtime_options_pass_through():
    backend = FakeManilaV2()
    sampler = runtime_sampler(backend, shots=123, seed=1, dynamical_decoupling="XY4",
                              twirling=True)
    assert sampler.options.default_shots == 123
    assert sampler.options.dynamical_decoupling.enable is True
    assert sampler.options.dynamical_decoupling.sequence_type == "XY4"
    assert sampler.options.twirling.enable_gates is True
    assert sampler.options.twirling.enable_measure is True
    assert runtime_options(dynamical_decoupling=False) == {"dynamical_decoupling":
                                                            {"enable": False}}


def test_noisy_runtime_forward_is_close_but_biased_by_the_snapshot():
    """With the snapshot's own noise, Z on a prepared |1> reads below 1 (readout errors)."""
    backend = FakeManilaV2()
    engine = runtime_engine(backend, seed=_stat_seed(3))
    qc = QuantumCircuit(2)
    qc.x(0)
    plan = expectation_plan(qc, SparsePauliOp(["IZ"]), [], shots=4000)
    est = plan.run(engine)
    # Oracle: -1 + 2 q, q the exact chance that the physical qubit reads 0 (tests/_noisy.py:
    # the compiled circuit's density matrix under the noise model the runtime's local mode
    # builds from the snapshot's properties, then its readout error, P(0 | 1) = 0.055 on
    # qubit 0; -0.89)
    local_noise = backend._get_noise_model_from_backend_v2()  # what backend.run simulates
    noisy = expected_estimate(plan, engine, local_noise)
    assert -1.0 < noisy.value[0] < -0.8  # biased, but not far
    # a mean of 4000 shots (normal): two-sided at 1e-10
    assert abs(est.value[0] - noisy.value[0]) <= norm.isf(0.5e-10) * est.standard_error[0]


# ---------------------------------------------------------------------------------- bad input


def test_options_the_runtime_rejects_raise_before_any_job():
    backend = FakeManilaV2()
    with pytest.raises(ValueError, match="rejected by the runtime"):
        runtime_sampler(backend, options={"shots": 5})
    with pytest.raises(ValueError, match="dynamical_decoupling"):
        runtime_sampler(backend, dynamical_decoupling="ZZZ")
    with pytest.raises(TypeError, match="twirling"):
        runtime_sampler(backend, twirling="yes")
    with pytest.raises(TypeError, match="backend"):
        runtime_engine("fake_manila")


def test_too_wide_or_unsupported_circuits_are_refused_before_submission():
    backend = FakeManilaV2()
    engine = runtime_engine(backend, seed=1)
    asked = _spy(engine)
    wide = QuantumCircuit(6)
    wide.h(range(6))
    wide.measure_all()
    with pytest.raises(ValueError, match="6 qubits.*fake_manila"):
        engine.run([CircuitJob(wide, None, 10, "wide")])
    raw = SamplerEngine(sampler=engine.sampler, transpiler=lambda c: c)
    small = QuantumCircuit(2)
    small.h(0)
    small.measure_all()
    with pytest.raises(ValueError, match=r"\['h'\].*cannot run"):
        raw.run([CircuitJob(small, None, 10, "untranspiled")])
    assert asked == []
    assert engine.ledger.total_shots == 0 and raw.ledger.total_shots == 0


def test_a_failed_job_leaves_the_ledger_unchanged():
    backend = FakeManilaV2()
    engine = runtime_engine(backend, seed=1)
    qc = QuantumCircuit(1)
    qc.x(0)
    job = CircuitJob(QuantumCircuit.copy(qc).measure_all(inplace=False), None, 50, "ok")
    engine.run([job])
    before = engine.ledger.total_shots
    assert before == 50

    class Failed:
        def result(self):
            raise RuntimeError("job failed on the device")

    engine.sampler.run = lambda pubs, **kw: Failed()
    with pytest.raises(RuntimeError, match="failed"):
        engine.run([job, job])
    assert engine.ledger.total_shots == before
