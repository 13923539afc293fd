"""Targets from objects: any BackendV2, a bare Target, a snapshot file (issue "Hardware as
objects", item 1). Oracles: the backend's own Target, coupling map and
``NoiseModel.from_backend``; ideal outcomes of circuits run through the engine; the widths the
error messages must name. No credentials: fake backends and the runtime's local mode."""

import json
import warnings

import numpy as np
import pytest
from qiskit import QuantumCircuit
from qiskit.providers.fake_provider import GenericBackendV2
from qiskit.quantum_info import SparsePauliOp
from qiskit.transpiler import PassManager, Target
from qiskit.transpiler.passes import CheckMap, GatesInBasis
from qiskit_aer import AerSimulator
from qiskit_aer.noise import NoiseModel, ReadoutError
from qiskit_ibm_runtime import SamplerV2 as RuntimeSamplerV2
from qiskit_ibm_runtime.fake_provider import FakeKolkataV2, FakeManilaV2

from qdensity.circuits.ansatze import round_robin
from qdensity.execution.plans import CircuitJob, expectation_plan, measured
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.hardware.resources import resource_report
from qdensity.hardware.snapshot_files import SNAPSHOT_VERSION, save_snapshot
from qdensity.hardware.targets import get_target


def _noise_dict(model: NoiseModel) -> list:
    """A noise model's errors without the random ids Aer gives them."""
    out = []
    for err in model.to_dict()["errors"]:
        err = dict(err)
        err.pop("id", None)
        out.append(json.dumps(err, sort_keys=True, default=str))
    return sorted(out)


def _edges(cmap) -> set:
    return {tuple(e) for e in cmap.get_edges()}


@pytest.mark.parametrize("make", [FakeManilaV2, FakeKolkataV2,
                                  lambda: GenericBackendV2(6, seed=4)],
                         ids=["manila", "kolkata", "generic"])
def test_backend_target_carries_its_device(make):
    backend = make()
    tgt = get_target(backend)
    assert tgt.backend is backend and tgt.target is backend.target
    assert tgt.num_qubits == backend.num_qubits
    assert _edges(tgt.coupling_map) == _edges(backend.coupling_map)
    assert set(tgt.basis_gates) <= set(backend.operation_names)
    assert _noise_dict(tgt.noise_model) == _noise_dict(NoiseModel.from_backend(backend))
    assert get_target(backend, noise=False).noise_model is None


def test_aer_simulator_from_backend_keeps_its_own_noise():
    sim = AerSimulator.from_backend(FakeManilaV2())
    tgt = get_target(sim)
    assert tgt.noise_model is sim.options.noise_model
    assert tgt.num_qubits == 5


def test_resource_report_on_a_backend_compiles_to_its_gates_and_edges():
    backend = FakeKolkataV2()
    rep = resource_report(round_robin(4), backend)
    assert rep.target == "fake_kolkata"
    assert set(rep.gate_counts) <= set(backend.operation_names)
    compiled = get_target(backend).transpile(round_robin(4))
    pm = PassManager([CheckMap(backend.coupling_map), GatesInBasis(target=backend.target)])
    pm.run(compiled)
    assert pm.property_set["is_swap_mapped"] and pm.property_set["all_gates_in_basis"]


def test_bare_target_with_and_without_a_noise_model():
    target = GenericBackendV2(3, seed=1).target
    qc = QuantumCircuit(3)
    qc.x(0)
    obs = SparsePauliOp("IIZ")
    ideal = expectation_plan(qc, obs, [], shots=400).run(
        SamplerEngine(target=target, seed=2, progress=False))
    assert ideal.value[0] == -1.0  # noiseless: every shot reads qubit 0 as 1
    noise = NoiseModel()
    noise.add_all_qubit_readout_error(ReadoutError([[0.7, 0.3], [0.3, 0.7]]))
    tgt = get_target(target, noise_model=noise)
    assert tgt.is_noisy and tgt.backend is None
    noisy = expectation_plan(qc, obs, [], shots=4000).run(
        SamplerEngine(target=tgt, seed=2, progress=False))
    # <Z> = -(1 - 2 * 0.3) = -0.4 under the flip; 4000 shots: se ~ 0.015
    assert abs(noisy.value[0] + 0.4) < 5 * noisy.standard_error[0]
    with pytest.raises(TypeError, match="NoiseModel"):
        get_target(target, noise_model="depolarising")
    with pytest.raises(ValueError, match="noise_model is accepted with a backend"):
        get_target("line", 3, noise_model=noise)


def test_narrow_device_is_refused_naming_both_widths_before_transpiling():
    with pytest.raises(ValueError, match=r"num_qubits 8 .*'fake_manila'.* 5 qubits"):
        get_target(FakeManilaV2(), 8)
    engine = SamplerEngine(target=FakeManilaV2(), seed=0, progress=False)
    job = CircuitJob(measured(round_robin(8)), np.zeros((1, round_robin(8).num_parameters)), 10)
    with pytest.raises(ValueError, match=r"needs 8 qubits but target .fake_manila. has 5"):
        engine.run([job])
    assert engine.transpile_count == 0
    with pytest.raises(ValueError, match=r"8 qubits.*fake_manila"):
        resource_report(round_robin(8), FakeManilaV2())


def test_runtime_local_mode_sampler_with_a_backend_target():
    backend = FakeManilaV2()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        sampler = RuntimeSamplerV2(mode=backend, options={"simulator": {"seed_simulator": 5}})
    engine = SamplerEngine(sampler=sampler, target=backend, progress=False)
    qc = QuantumCircuit(2)
    qc.x(1)
    est = expectation_plan(qc, SparsePauliOp("ZI"), [], shots=2000).run(engine)
    # ideal -1; manila's readout and gate errors are a few percent
    assert -1.0 <= est.value[0] < -0.85
    assert engine.ledger.total_shots == 2000


def test_snapshot_file_round_trip(tmp_path):
    backend = FakeManilaV2()
    path = save_snapshot(backend, tmp_path / "manila.json")
    tgt = get_target(str(path))
    assert tgt.name == "fake_manila" and tgt.num_qubits == 5
    assert _edges(tgt.coupling_map) == _edges(backend.coupling_map)
    for name in backend.target.operation_names:
        for qargs, props in backend.target[name].items():
            got = tgt.target[name][qargs]
            if props is None:
                assert got is None or (got.error is None and got.duration is None)
            else:
                assert got.error == props.error and got.duration == props.duration
    for a, b in zip(backend.target.qubit_properties, tgt.target.qubit_properties, strict=True):
        assert (a.t1, a.t2, a.frequency) == (b.t1, b.t2, b.frequency)
    assert _noise_dict(tgt.noise_model) == _noise_dict(NoiseModel.from_backend(backend))
    assert get_target(path).num_qubits == 5  # a Path works too


def test_bad_snapshot_files_are_refused(tmp_path):
    with pytest.raises(ValueError, match="path must be the path of an existing file"):
        get_target(str(tmp_path / "missing.json"))
    junk = tmp_path / "junk.json"
    junk.write_text("not json at all")
    with pytest.raises(ValueError, match="not a qdensity device snapshot.*not JSON"):
        get_target(str(junk))
    other = tmp_path / "other.json"
    other.write_text(json.dumps({"hello": 1}))
    with pytest.raises(ValueError, match="not a qdensity device snapshot.*format"):
        get_target(str(other))
    path = save_snapshot(FakeManilaV2(), tmp_path / "m.json")
    data = json.loads(path.read_text())
    data["version"] = SNAPSHOT_VERSION + 1
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match=rf"format version {SNAPSHOT_VERSION + 1}, newer"):
        get_target(str(path))


def test_target_builders_have_an_upper_bound_checked_first():
    for name in ("heavy_hex", "line", "ring", "all_to_all", "ideal", "rbs_native"):
        with pytest.raises(ValueError, match=r"num_qubits must be an int >= 1.*<= 4096.*1000000"):
            get_target(name, 10**6)
    with pytest.raises(TypeError, match="BackendV2 or a qiskit.transpiler.Target"):
        get_target(3.5, 2)
    with pytest.raises(ValueError, match="fixed number of qubits"):
        get_target(Target())
