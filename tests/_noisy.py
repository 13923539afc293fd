"""Exact expectations of sampled estimates on a noisy simulated device (an oracle for tests).

A device simulated by Aer applies its noise model's gate errors to the circuit and then flips
each measured bit with the qubit's readout error. So the distribution a sampler draws from is
exactly: the density-matrix simulation of the compiled circuit under the same noise model
(outcome probabilities of the measured qubits before readout) times the readout matrices, one
per measured qubit. Estimates that are linear in the frequencies (expectation values, shift-
rule gradients) then have the expectation the plan's post-processing gives on these
probabilities; a readout-mitigated estimate converges to the correction, by the readout
matrices a calibration on the same device converges to, of these probabilities.
"""

from __future__ import annotations

import numpy as np
from qiskit import QuantumCircuit
from qiskit_aer import AerSimulator

from qdensity.execution.job_results import JobResult


def readout_matrices(noise_model, qubits) -> np.ndarray:
    """``(m, 2, 2)``: ``A[j][r, s]`` the chance that qubit ``qubits[j]`` in ``s`` reads ``r``
    (the noise model's readout errors, its all-qubit one where a qubit has none of its own)."""
    local, default = {}, np.eye(2)
    for err in noise_model.to_dict()["errors"]:
        if err["type"] != "roerror":
            continue
        probs = np.array(err["probabilities"], dtype=float)  # [true, read]
        if "gate_qubits" in err:
            for qs in err["gate_qubits"]:
                local[qs[0]] = probs
        else:
            default = probs
    return np.array([local.get(q, default).T for q in qubits])


def _apply_readout(probs: np.ndarray, mats: np.ndarray) -> np.ndarray:
    full = np.ones((1, 1))
    for a in mats[::-1]:  # clbit m - 1 is the most significant
        full = np.kron(full, a)
    return probs @ full.T


def measured_qubits(compiled: QuantumCircuit) -> list[int]:
    """Physical qubit measured into each clbit."""
    out = {}
    for inst in compiled.data:
        if inst.operation.name == "measure":
            out[compiled.find_bit(inst.clbits[0]).index] = compiled.find_bit(inst.qubits[0]).index
    return [out[c] for c in range(compiled.num_clbits)]


def noisy_probabilities(compiled: QuantumCircuit, noise_model, template: QuantumCircuit,
                        values=None, *, readout: bool = True) -> np.ndarray:
    """Exact outcome probabilities ``(rows, 2**m)`` of a compiled, measured circuit on the
    device ``noise_model`` describes; ``values`` rows bind ``template``'s parameters (the
    compiled circuit keeps their names). ``readout=False``: before the readout errors."""
    qubits = measured_qubits(compiled)
    bare = compiled.copy_empty_like()
    for inst in compiled.data:
        if inst.operation.name not in ("measure", "barrier"):
            bare.append(inst)
    bare.save_probabilities(qubits)
    sim = AerSimulator(method="density_matrix", noise_model=noise_model)
    names = {p.name: p for p in bare.parameters}
    rows = np.zeros((1, 0)) if values is None else np.atleast_2d(values)
    out = []
    for row in rows:
        bind = {names[p.name]: v for p, v in zip(template.parameters, row, strict=True)
                if p.name in names}
        res = sim.run(bare.assign_parameters(bind) if bind else bare, shots=1).result()
        out.append(res.data(0)["probabilities"])
    probs = np.array(out, dtype=float)
    return _apply_readout(probs, readout_matrices(noise_model, qubits)) if readout else probs


def expected_estimate(plan, engine, noise_model=None):
    """What ``plan.run(engine)`` estimates on average (plans linear in the frequencies):
    its post-processing of the exact noisy probabilities of every job, as compiled
    (``noise_model``: the device's, default the engine target's)."""
    nm = engine.target.noise_model if noise_model is None else noise_model
    results = [JobResult(noisy_probabilities(engine.compiled(job.circuit), nm, job.circuit,
                                             job.values), None, job)
               for job in plan.jobs]
    return plan.postprocess(results)


def calibrated_matrices(noise_model, num_qubits: int, qubits) -> np.ndarray:
    """``(m, 2, 2)``: the readout matrices mthree's calibration on this device converges to
    (a simulator is calibrated qubit by qubit: nothing, or an X gate with its own noise, then
    the measurement)."""
    mats = readout_matrices(noise_model, qubits)
    out = []
    for q, a in zip(qubits, mats, strict=True):
        qc = QuantumCircuit(num_qubits)
        qc.x(q)
        qc.save_probabilities([q])
        pre = AerSimulator(method="density_matrix", noise_model=noise_model).run(
            qc, shots=1).result().data(0)["probabilities"]
        out.append(np.column_stack([a[:, 0], a @ np.asarray(pre)]))
    return np.array(out)


def mitigated_value(probs: np.ndarray, cal: np.ndarray, h: np.ndarray, keep=None) -> np.ndarray:
    """``sum_S q h / sum_S q`` with ``q = cal^-1 probs`` (rows ``(rows, 2**m)``)."""
    inv = np.linalg.inv(cal)
    q = _apply_readout(probs, inv)
    keep = np.ones(probs.shape[1], dtype=bool) if keep is None else keep
    return (q[:, keep] @ h[keep]) / q[:, keep].sum(axis=1)
