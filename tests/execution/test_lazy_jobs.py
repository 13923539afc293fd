"""Jobs built on read (LazyCircuitJob) and their compiled unary programs: the circuit a user
reads is the measured template written out independently here; the program's outcome
probabilities are the statevector's of that circuit; the engine draws from the program the
shots it would draw from the circuit; the jobs pickle and copy without their circuit."""

from __future__ import annotations

import copy
import pickle
from functools import partial

import numpy as np
import pytest
from qiskit import ClassicalRegister, QuantumCircuit
from qiskit.circuit import Parameter
from qiskit.quantum_info import Statevector

from qdensity import DensityQNN, Encoding, SamplerEngine, by_moments
from qdensity.circuits._copying import concatenated_view
from qdensity.circuits.ansatze import round_robin
from qdensity.circuits.gates import RBSGate
from qdensity.execution._lazy_jobs import LazyCircuitJob, unary_programs
from qdensity.execution.plans import CircuitJob, Plan
from qdensity.execution.samplers._hamming_compile import CompiledPrefix, compile_template
from qdensity.execution.samplers._hamming_program import _Compiled
from qdensity.gradients import density_gradient_plan


def _model(n: int) -> DensityQNN:
    subs = by_moments(round_robin(n)).sub_unitaries
    return DensityQNN(subs, encoding=Encoding.unary(n), readout="unary_probabilities", seed=0)


def _expected_jacobian_circuit(model, k: int, pairs) -> QuantumCircuit:
    """``V(x) U_k``, a barrier, ``RBS(pi/4)`` on each pair, every qubit measured into its clbit:
    written gate by gate from the model's own circuits."""
    n = model.num_qubits
    qc = QuantumCircuit(n)
    for circ in (model.encoding.circuit, model.sub_unitaries[k]):
        for inst in circ.data:
            qc.append(inst.operation, [circ.find_bit(q).index for q in inst.qubits])
    qc.barrier()
    for i, j in pairs:
        qc.append(RBSGate(np.pi / 4), [i, j])
    qc.add_register(ClassicalRegister(n, "meas"))
    qc.measure(range(n), range(n))
    return qc


def _same_instructions(a: QuantumCircuit, b: QuantumCircuit) -> None:
    assert a.num_qubits == b.num_qubits and a.num_clbits == b.num_clbits
    assert len(a.data) == len(b.data)
    for x, y in zip(a.data, b.data, strict=True):
        assert x.operation.name == y.operation.name
        assert [a.find_bit(q).index for q in x.qubits] == [b.find_bit(q).index for q in y.qubits]
        assert [a.find_bit(c).index for c in x.clbits] == [b.find_bit(c).index for c in y.clbits]
        assert [str(p) for p in x.operation.params] == [str(p) for p in y.operation.params]


def test_sampled_plan_jobs_are_built_on_read_and_are_the_measured_templates():
    n = 6
    model = _model(n)
    X = np.random.default_rng(0).normal(size=(3, n))
    plan = density_gradient_plan(model, X, method="commuting", shots=50)
    K = model.num_subunitaries
    assert len(plan.jobs) == 2 * K
    for k in range(K):
        jac, fwd = plan.jobs[k], plan.jobs[K + k]
        assert isinstance(jac, LazyCircuitJob) and isinstance(fwd, CircuitJob)
        pairs = [tuple(model.sub_unitaries[k].find_bit(q).index for q in inst.qubits)
                 for inst in model.sub_unitaries[k].data]
        _same_instructions(jac.circuit, _expected_jacobian_circuit(model, k, pairs))
        assert isinstance(fwd.circuit, QuantumCircuit)
        assert fwd.circuit.num_clbits == n and fwd.num_qubits == n
        assert jac.values.shape == (3, jac.circuit.num_parameters)


@pytest.mark.parametrize("prefixed", [False, True])
@pytest.mark.parametrize("n", [4, 7])
def test_unary_program_probabilities_are_the_statevector_of_the_circuit(n, prefixed):
    """Oracle: qiskit's Statevector of the (unmeasured) circuit, read on the weight-1 states;
    ``prefixed``: the program compiled after the loader's walk done once (and the circuit a
    view sharing the model's gates), as a density gradient plan compiles it."""
    model = _model(n)
    rng = np.random.default_rng(n)
    k = 1
    circ = model.circuit(k)
    pairs = [(0, 1), (2, 3)]
    if prefixed:
        view = concatenated_view(model.encoding.circuit, model.sub_unitaries[k])
        progs = unary_programs(view, pairs, CompiledPrefix(model.encoding.circuit))
    else:
        progs = unary_programs(circ, pairs)
    assert progs is not None
    with_layer, alone = progs
    values = rng.uniform(-np.pi, np.pi, (3, circ.num_parameters))
    layered = circ.copy()
    for i, j in pairs:
        layered.append(RBSGate(np.pi / 4), [i, j])
    for prog, qc in ((with_layer, layered), (alone, circ)):
        got = _Compiled.from_program(prog).probabilities(values)
        for r in range(values.shape[0]):
            bound = qc.assign_parameters(dict(zip(qc.parameters, values[r], strict=True)))
            probs = Statevector(bound).probabilities()
            want = probs[1 << np.arange(n)]
            np.testing.assert_allclose(got[r], want, atol=1e-12)


def _gate_list(template) -> list:
    return [(g.name, g.qubits, g.angles, g.matrix is None, g.operation, g.position)
            for g in template.gates]


@pytest.mark.parametrize("n", [3, 6])
def test_a_template_compiled_after_a_prefix_is_the_whole_walk(n):
    """Every V(x) U_k compiled after the loader's walk gives the gate list, angles (parameter
    columns renumbered to the whole circuit's), input and measurements of walking it whole."""
    model = _model(n)
    prefix = CompiledPrefix(model.encoding.circuit)
    assert prefix.ok
    for k in range(model.num_subunitaries):
        circ = model.circuit(k)
        circ.measure_all()
        whole, after = compile_template(circ), compile_template(circ, prefix=prefix)
        assert _gate_list(after) == _gate_list(whole)
        assert after.parameters == whole.parameters and after.occupied == whole.occupied
        assert after.measured == whole.measured and after.flipped == whole.flipped


def test_a_prefix_it_cannot_cover_is_walked_with_the_rest():
    """A prefix with a flip still pending, or one a circuit does not hold the parameters of,
    leaves the whole walk to compile_template: the same template as without it."""
    pending = QuantumCircuit(2)
    pending.x(0)
    pending.append(RBSGate(0.2), [0, 1])
    pending.x(1)  # a relabelling pending on qubit 1
    assert not CompiledPrefix(pending).ok
    theta = Parameter("t")
    loader = QuantumCircuit(2)
    loader.x(0)
    loader.append(RBSGate(theta), [0, 1])
    prefix = CompiledPrefix(loader)
    assert prefix.ok
    other = QuantumCircuit(2)  # the same shape, another parameter: not this prefix's circuit
    other.x(0)
    other.append(RBSGate(Parameter("s")), [0, 1])
    other.append(RBSGate(0.4), [0, 1])
    other.measure_all()
    assert _gate_list(compile_template(other, prefix=prefix)) == _gate_list(
        compile_template(other))


def test_engine_draws_from_the_program_the_shots_of_the_circuit():
    """The same rows and seed: a job sampled from its program gives the bits of the same job
    sampled from its (built) circuit, noiseless and with a readout error."""
    n = 6
    model = _model(n)
    X = np.random.default_rng(2).normal(size=(4, n))
    plan = density_gradient_plan(model, X, method="commuting", shots=64)
    eager = [CircuitJob(j.circuit, j.values, j.shots, j.label) for j in plan.jobs]
    for seed in (0, 11):
        lazy_res = SamplerEngine(seed=seed, progress=False).run(plan.jobs)
        eager_res = SamplerEngine(seed=seed, progress=False).run(eager)
        for a, b in zip(lazy_res, eager_res, strict=True):
            np.testing.assert_array_equal(a.bits, b.bits)


def test_non_unary_templates_fall_back_to_no_program():
    qc = QuantumCircuit(3)
    qc.x(0)
    qc.x(1)  # weight 2: the subspace engine, not a unary program
    qc.append(RBSGate(0.3), [0, 2])
    assert unary_programs(qc, [(0, 1)]) is None


def test_lazy_job_pickles_copies_and_changes_shots_without_its_circuit():
    n = 5
    model = _model(n)
    X = np.random.default_rng(3).normal(size=(2, n))
    job = density_gradient_plan(model, X, method="commuting", shots=20).jobs[0]
    assert isinstance(job, LazyCircuitJob)
    held = job.circuit
    assert job.circuit is held  # the same object while someone holds it
    for other in (pickle.loads(pickle.dumps(job)), copy.deepcopy(job), job.with_shots(7)):
        assert isinstance(other, LazyCircuitJob)
        _same_instructions(other.circuit, held)
        np.testing.assert_array_equal(other.values, job.values)
    assert job.with_shots(7).shots == 7 and job.with_shots(None).shots is None
    plan = Plan([job], lambda r: r)
    assert plan.with_shots(9).jobs[0].shots == 9


def test_lazy_job_checks_its_arguments():
    build = partial(QuantumCircuit, 2, 2)
    with pytest.raises(TypeError, match="build"):
        LazyCircuitJob("not callable", 2, 0, np.zeros((1, 0)))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="values"):
        LazyCircuitJob(build, 2, 3, np.zeros((2, 2)), 10)
    with pytest.raises(ValueError, match="at least one parameter row"):
        LazyCircuitJob(build, 2, 2, np.zeros((0, 2)), 10)
    with pytest.raises(TypeError, match="label"):
        LazyCircuitJob(build, 2, 0, np.zeros((1, 0)), 10, 3)  # type: ignore[arg-type]


def test_a_deferred_program_keeps_no_layers_after_a_draw():
    """A program held until its shots are read drops what the unary engine caches on it (the
    names checked against UnaryCircuit's cached properties themselves)."""
    from functools import cached_property

    from qdensity.execution.samplers._hamming_program import cached_names
    from qdensity.execution.unary import UnaryCircuit

    cached = {k for k, v in vars(UnaryCircuit).items() if isinstance(v, cached_property)}
    assert {"layers", "_plan"} <= cached <= set(cached_names())
    model = _model(5)
    progs = unary_programs(model.circuit(0), [(0, 1)])
    assert progs is not None
    comp = _Compiled.from_program(progs[0])
    comp.probabilities(np.zeros((2, progs[0].unary.num_parameters)))
    assert not cached & set(vars(progs[0].unary))
