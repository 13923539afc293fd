"""Shots drawn from the exact noisy output distribution of a few-qubit circuit.

A noisy circuit on ``a`` active qubits has an exact output distribution: evolve the
``2**a x 2**a`` density matrix through every gate followed by the noise model's error on that
gate (the channel Aer's ``density_matrix`` method applies), take its diagonal on the measured
qubits and pass it through the readout errors. Shots are then independent draws from that
distribution: exact for the circuit and the noise model given, with no trajectory sampling.
For a few qubits this is cheap (a 64 x 64 matrix at ``a = 6``), and most of the cost of a
simulator call there is overhead: :class:`ExactNoisySampler` fuses each run of gates on at most
two qubits (their errors included) into one superoperator, built per parameter row only where
the gates are parametrised, and evolves every parameter row of a PUB at once.

What it reads of a noise model, through public API only (``NoiseModel.to_dict()``,
``QuantumError.from_dict``, ``qiskit.quantum_info.Kraus``): quantum errors on instructions
(a qubit-specific error replaces the all-qubit one of the same instruction, as in Aer;
an error on ``measure`` acts before the measurement, as in Aer) and single-qubit readout
errors. :func:`supported` says whether a circuit and noise model are within that: only
terminal measurements, no ``reset``, ``delay``, conditions or classical control, and no
correlated (multi-qubit) readout error; anything else goes to Aer.

Correctness oracle (``tests/execution/test_noisy_exact.py``): the probabilities equal Aer's
``density_matrix`` method's to 1e-10, and the drawn counts pass a chi-square test.
"""

from __future__ import annotations

import weakref
import zlib

import numpy as np
from qiskit.circuit import QuantumCircuit
from qiskit.primitives import BaseSamplerV2, BitArray, DataBin, PrimitiveResult, SamplerPubResult
from qiskit.primitives.containers import SamplerPub
from qiskit_aer.noise import NoiseModel

from qdensity.execution.samplers._jobs import LocalJob
from qdensity.execution.samplers._noise_tables import NoiseTables
from qdensity.execution.samplers._noisy_program import (
    MAX_QUBITS,
    Program,
    active_count,
    exact_probabilities,
    supported,
)
from qdensity.validation import MAX_SHOTS, Instance, Interval, validates

__all__ = ["ExactNoisySampler", "ExactRoute", "NoiseTables", "supported",
           "exact_probabilities", "exact_from", "MAX_QUBITS"]

@validates(noise_model=[Instance(NoiseModel), None], seed=[Interval(int, 0), None],
           default_shots=Interval(int, 1, MAX_SHOTS))
class ExactNoisySampler(BaseSamplerV2):
    """A ``BaseSamplerV2`` whose shots are draws from each row's exact noisy distribution.

    Parameters
    ----------
    noise_model : NoiseModel or None
        The noise of the (transpiled) circuits it samples.
    seed : int or None
        Seeds the draws: the same seed and PUBs give the same shots (as a seeded Aer sampler;
        None draws fresh ones every call).
    default_shots : int

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> qc = QuantumCircuit(2)
    >>> _ = qc.h(0)
    >>> _ = qc.cx(0, 1)
    >>> _ = qc.measure_all()
    >>> res = ExactNoisySampler(None, seed=1).run([qc], shots=100).result()[0]
    >>> sorted(res.data.meas.get_counts())
    ['00', '11']
    """

    def __init__(self, noise_model: NoiseModel | None, seed: int | None = None,
                 default_shots: int = 1024):
        self.tables = NoiseTables(noise_model)  # read when first needed, as the model is then
        self._seed = seed
        self._default_shots = int(default_shots)
        self._programs: dict[int, tuple] = {}
        self._facts: dict[int, tuple] = {}

    @property
    def seed(self) -> int | None:
        """The seed of the draws."""
        return self._seed

    def supports(self, circuit: QuantumCircuit) -> bool:
        """Whether this sampler computes ``circuit`` (:func:`supported`, at most
        :data:`MAX_QUBITS` active qubits)."""
        active, ok = self.facts(circuit)
        return ok and active <= MAX_QUBITS

    def facts(self, circuit: QuantumCircuit) -> tuple[int, bool]:
        """``(active qubits, supported(circuit))``, read once per circuit object while it
        lives (a template runs once per training step)."""
        key = id(circuit)
        hit = self._facts.get(key)
        if hit is not None and hit[0]() is circuit:
            return hit[1]
        facts = (active_count(circuit), supported(circuit, self.tables))
        self._facts[key] = (weakref.ref(circuit), facts)
        return facts

    def program(self, circuit: QuantumCircuit) -> Program:
        """``circuit`` compiled (once per circuit object while it lives)."""
        key = id(circuit)
        hit = self._programs.get(key)
        if hit is not None and hit[0]() is circuit:
            return hit[1]
        prog = Program(circuit, self.tables)
        self._programs[key] = (weakref.ref(circuit), prog)
        return prog

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_programs"] = {}  # weak references do not pickle; compiled again on use
        state["_facts"] = {}
        return state

    def run(self, pubs, *, shots: int | None = None) -> LocalJob:
        """Sample ``pubs``: a job whose result holds one ``SamplerPubResult`` per PUB."""
        shots = self._default_shots if shots is None else shots
        coerced = [SamplerPub.coerce(pub, shots) for pub in pubs]
        for i, pub in enumerate(coerced):
            if not self.supports(pub.circuit):
                raise ValueError(f"pubs[{i}]: circuit {pub.circuit.name!r} is outside what "
                                 f"ExactNoisySampler computes (see qdensity.execution."
                                 f"samplers.noisy_exact.supported; at most {MAX_QUBITS} "
                                 f"active qubits)")
        return LocalJob(lambda: PrimitiveResult(self.sample(coerced, self._seed),
                                                metadata={"version": 2}))

    def sample(self, pubs: list[SamplerPub], seed: int | None) -> list[SamplerPubResult]:
        """One result per coerced PUB, its shots drawn from a stream of ``seed``, the PUB's
        position, circuit (its instructions' checksum, not its name), shots and parameter
        values: the same seed and PUBs give the same shots in any process (as a seeded Aer
        sampler's), other parameter values independent ones (a training step's shots are not
        the previous step's random numbers again)."""
        return [self._one(pub, i, seed) for i, pub in enumerate(pubs)]

    def _one(self, pub: SamplerPub, position: int, seed: int | None) -> SamplerPubResult:
        prog = self.program(pub.circuit)
        shape = pub.parameter_values.shape
        rows = int(np.prod(shape)) if shape else 1
        if prog.parameters:
            bound = pub.parameter_values.as_array(prog.parameters).reshape(rows, -1)
        else:
            bound = np.zeros((rows, 0))
        bound = np.ascontiguousarray(bound, dtype=float)
        rng = np.random.default_rng(None if seed is None else [
            int(seed) % 2**63, 0xE8AC7, position, pub.shots,
            prog.fingerprint, zlib.crc32(bound.tobytes())])
        probs = exact_probabilities(prog, np.asarray(bound, dtype=float))
        cdf = np.cumsum(probs, axis=1)
        cdf[:, -1] = 1.0
        u = rng.random((rows, pub.shots))
        outcome = np.empty((rows, pub.shots), dtype=np.int64)
        for r in range(rows):
            outcome[r] = np.searchsorted(cdf[r], u[r], side="right")
        clbits = np.zeros((rows, pub.shots, prog.num_clbits), dtype=bool)
        for i, (_, c) in enumerate(prog.measure):
            clbits[:, :, c] = (outcome >> i) & 1
        data = {}
        for name, members in prog.cregs:
            bits = clbits[:, :, members][:, :, ::-1]  # big-endian: the last clbit first
            nb = len(members)
            pad = np.zeros(bits.shape[:-1] + ((-nb) % 8,), dtype=bool)  # right-aligned bytes
            packed = np.packbits(np.concatenate([pad, bits], axis=-1), axis=-1)
            data[name] = BitArray(packed.reshape(shape + (pub.shots, packed.shape[-1])), nb)
        return SamplerPubResult(DataBin(**data, shape=shape),
                                metadata={"shots": pub.shots,
                                          "circuit_metadata": pub.circuit.metadata})


@validates(num_active=Interval(int, 0))
def exact_from(num_active: int) -> int:
    """Shots per row from which the exact distribution costs less than Aer (measured).

    On the demo's 6-qubit templates transpiled for a noisy heavy-hex device (one thread, 2
    busy cores) the exact distribution cost 3 ms a row (31 fused blocks) against 0.6 ms a
    shot for Aer's trajectories and 17 ms a row for Aer's density matrix: cheaper from 5 shots.
    Both the exact cost (``4 ** a``) and the trajectories' (``2 ** a`` a shot) grow with the
    active qubits ``a``, so the crossover doubles per qubit.

    Parameters
    ----------
    num_active : int

    Returns
    -------
    int
        ``ceil(5 * 2 ** (a - 6))``: 2 at 4 qubits, 5 at 6, 20 at 8, 80 at 10.

    Examples
    --------
    >>> [exact_from(a) for a in (4, 6, 8, 10)]
    [2, 5, 20, 80]
    """
    return int(np.ceil(5 * 2.0 ** (int(num_active) - 6)))


class ExactRoute:
    """The PUBs of a noisy Aer sampler's call that run as exact noisy distributions.

    :class:`~qdensity.execution.samplers.aer.AdaptiveSampler` hands every call's PUBs to
    :meth:`take` first: a PUB on at most :data:`MAX_QUBITS` active qubits, within
    :func:`supported`, with at least :func:`exact_from` shots, is drawn here from its exact
    distribution under the simulators' noise model; the others go to Aer.

    Parameters
    ----------
    make_simulator : callable
        ``make_simulator(method) -> AerSimulator``; its ``options.noise_model`` is the noise.
    noisy : bool
        Whether those simulators carry noise (noiseless PUBs stay with Aer).

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> from qiskit.primitives.containers import SamplerPub
    >>> from qiskit_aer import AerSimulator
    >>> from qiskit_aer.noise import depolarizing_error
    >>> model = NoiseModel()
    >>> model.add_all_qubit_quantum_error(depolarizing_error(0.05, 1), ["x"])
    >>> route = ExactRoute(lambda m: AerSimulator(method=m, noise_model=model), noisy=True)
    >>> qc = QuantumCircuit(2)
    >>> _ = qc.x(0)
    >>> _ = qc.measure_all()
    >>> out = [None]
    >>> route.take([SamplerPub.coerce(qc, 100)], out, seed=1, overrides={})
    {0}
    >>> out[0].data.meas.num_shots
    100
    >>> route.take([SamplerPub.coerce(qc, 100)], [None], 1, {"method": "statevector"})
    set()
    """

    def __init__(self, make_simulator, noisy: bool):
        self._make_simulator, self._noisy = make_simulator, bool(noisy)
        self._sampler: ExactNoisySampler | None = None

    def _exact(self) -> ExactNoisySampler:
        if self._sampler is None:
            noise = self._make_simulator("density_matrix").options.noise_model
            self._sampler = ExactNoisySampler(noise if isinstance(noise, NoiseModel) else None)
        return self._sampler

    def take(self, pubs: list[SamplerPub], out: list, seed: int | None,
             overrides: dict) -> set[int]:
        """Fill ``out[i]`` for the PUBs drawn here; returns their indices.

        Parameters
        ----------
        pubs : list of SamplerPub
        out : list
            One slot per PUB.
        seed : int or None
            The calling sampler's seed.
        overrides : dict
            The caller's Aer options: a fixed ``method`` keeps every PUB with Aer.
        """
        if not self._noisy or "method" in overrides:
            return set()
        exact = self._exact()
        chosen = []
        for i, pub in enumerate(pubs):
            active, ok = exact.facts(pub.circuit)
            if ok and active <= MAX_QUBITS and pub.shots >= exact_from(active):
                chosen.append(i)
        if chosen:
            results = exact.sample([pubs[i] for i in chosen], seed)
            for i, res in zip(chosen, results, strict=True):
                out[i] = res
        return set(chosen)
