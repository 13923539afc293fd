"""The running and assembly of a :class:`~qdensity.execution.sampler.SamplerEngine` run.

The engine prepares every job (checks, transpilation, the PUB: :class:`PendingJob`);
:func:`sample_pending` submits the PUBs (the Hamming-weight sampler's drawn when read, the
rest in one job per shot count, :func:`~qdensity.execution.samplers.reseed.run_independent`);
:func:`assemble` turns the answers into results, weighs them with the engine's readout
correction and writes the ledger, only once every answer is back.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from qiskit.circuit import QuantumCircuit

from qdensity.execution.plans import CircuitJob, JobResult
from qdensity.execution.sampler._packed_result import PackedJobResult, bitarray_to_bits
from qdensity.execution.samplers._hamming_draw import DeferredSamples
from qdensity.execution.samplers.reseed import run_independent

__all__: list[str] = []


@dataclass
class PendingJob:
    """One prepared job: its PUB (or, for the Hamming-weight sampler, a ``ProgramItem``), and
    what assembly reads (the compiled circuit, or for the Hamming-weight sampler the weight
    marker the correction reads)."""

    job: CircuitJob
    label: str
    shots: int
    pub: tuple
    compiled: QuantumCircuit | None
    hamming: bool


def sample_pending(pending: list[PendingJob], hamming_sampler, sampler,
                   wait: Callable) -> list:
    """Submit the PUBs: one answer per job, in order (a ``DeferredSamples`` for the
    Hamming-weight sampler's, a ``SamplerPubResult`` otherwise)."""
    raw: list = [None] * len(pending)
    hw = [i for i, p in enumerate(pending) if p.hamming]
    aer = [i for i, p in enumerate(pending) if not p.hamming]
    if hw:
        # drawn when read (each PUB from its own stream): without a correction to weigh
        # them now, when the post-processing reads them, one job at a time
        # (a LazyCircuitJob's precompiled program in place of its PUB: no circuit built)
        for i, res in zip(hw, hamming_sampler.defer_programs([pending[i].pub for i in hw]),
                          strict=True):
            raw[i] = res
    if aer:
        for i, res in zip(aer, run_independent(sampler, [pending[i].pub for i in aer], wait),
                          strict=True):
            raw[i] = res
    return raw


def assemble(pending: list[PendingJob], raw: list, correction, ledger,
             sampler_name: str) -> list[JobResult]:
    """Results from the answers: bits, the correction's weights, one ledger entry per job."""
    results: list[JobResult] = []
    for p, pub_result in zip(pending, raw, strict=True):
        job, shots = p.job, p.shots
        if isinstance(pub_result, DeferredSamples):
            # drawn when read; with a correction to weigh them, drawn now
            packed = pub_result if correction is None else pub_result.bitarray()
        else:
            data = pub_result.data
            packed = next(iter(data.values())) if len(data) == 1 else pub_result.join_data()
        bits = None if p.hamming else bitarray_to_bits(packed, job.rows, shots)
        weights = n_eff = lins = None
        if correction is not None:
            weights, n_eff, lins = correction.weights(
                bitarray_to_bits(packed, job.rows, shots) if bits is None else bits,
                p.compiled, ledger)
        ledger.record(p.label, job.rows, job.rows * shots,
                      "hamming_weight" if p.hamming else sampler_name)
        if p.hamming:  # kept packed until read: device widths hold every job's shots
            results.append(PackedJobResult(packed, job.rows, shots, job, weights=weights,
                                           effective_shots=n_eff, readout=lins))
        else:
            results.append(JobResult(None, shots, job, bits=bits, weights=weights,
                                     effective_shots=n_eff, readout=lins))
    return results
