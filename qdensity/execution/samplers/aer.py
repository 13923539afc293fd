"""qdensity's Aer samplers: ``BaseSamplerV2`` implementations on qiskit-aer's public API.

:class:`AdaptiveSampler` picks Aer's method and options per PUB (the rule and its measurements
are in :mod:`qdensity.hardware.aer_sampling`) and :class:`AerSampler` runs on one given
simulator. Both submit to qiskit-aer's public ``SamplerV2.from_backend(simulator, seed=...)``
and configure simulators with ``AerSimulator.set_options``; neither reads or writes a private
attribute of a qiskit or qiskit-aer object, so a qiskit-aer release that renames its internals
changes nothing here. Both offer ``with_seed``, through which PUBs of different shot counts get
independent seeds (:mod:`qdensity.execution.samplers.reseed`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from qiskit.circuit import QuantumCircuit
from qiskit.primitives import BaseSamplerV2, PrimitiveResult
from qiskit.primitives.containers import SamplerPub
from qiskit_aer import AerSimulator
from qiskit_aer.primitives import SamplerV2

from qdensity.execution.samplers._jobs import LocalJob
from qdensity.execution.samplers.noisy_exact import ExactRoute
from qdensity.hardware.aer_sampling import (
    HAMMING_WEIGHT_KEY,
    MPS_MAX_BOND,
    _fits,
    active_qubits,
    aer_options,
    aer_seed,
    check_memory,
    mps_bond_bound,
)
from qdensity.validation import CallableC, Instance, Interval, Shots, Unchecked, validates

__all__ = ["AdaptiveSampler", "AerSampler", "NoiselessSimulators", "derived_seed",
           "sampler_method"]


@validates(seed=Interval(int))
def derived_seed(seed: int, *words: int) -> int:
    """A seed for a group of PUBs, derived from a sampler's ``seed`` (uint32, reproducible).

    Parameters
    ----------
    seed : int
    *words : int
        Distinguish the groups (``derived_seed(s, g)`` for shot group ``g``).

    Returns
    -------
    int
        In ``[0, 2**32)``; the same arguments give the same seed.

    Examples
    --------
    >>> derived_seed(5, 1) == derived_seed(5, 1), derived_seed(5, 1) == derived_seed(5, 2)
    (True, False)
    >>> 0 <= derived_seed(5, 1) < 2**32
    True
    """
    seq = np.random.SeedSequence([int(seed) % 2**63, *map(int, words)])
    return int(seq.generate_state(1, dtype=np.uint32)[0])


def _by_shots(pubs: list[SamplerPub]) -> dict[int, list[int]]:
    groups: dict[int, list[int]] = {}
    for i, pub in enumerate(pubs):
        groups.setdefault(pub.shots, []).append(i)
    return groups


@validates(simulator=Instance(AerSimulator), seed=[Interval(int), None],
           default_shots=Shots())
class AerSampler(BaseSamplerV2):
    """A seeded qiskit-aer sampler on a given ``AerSimulator``, built on public API only.

    Each ``run`` submits to qiskit-aer's ``SamplerV2.from_backend(simulator, seed=seed)``: the
    same counts as that sampler, and :meth:`with_seed` gives a copy with another seed (what
    :func:`qdensity.execution.samplers.reseed.run_independent` needs to give PUBs of
    different shot counts independent shots).

    Parameters
    ----------
    simulator : AerSimulator
        Carries the method, the noise and the options.
    seed : int or None
    default_shots : int

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> qc = QuantumCircuit(1)
    >>> _ = qc.x(0)
    >>> _ = qc.measure_all()
    >>> sampler = AerSampler(AerSimulator(method="statevector"), seed=3, default_shots=50)
    >>> sampler.run([qc]).result()[0].data.meas.get_counts()
    {'1': 50}
    >>> sampler.with_seed(4).seed
    4
    """

    def __init__(self, simulator: AerSimulator, seed: int | None = None,
                 default_shots: int = 1024):
        self.simulator = simulator
        self._seed = seed
        self._default_shots = int(default_shots)

    @property
    def seed(self) -> int | None:
        """The seed of every run (None: Aer draws its own)."""
        return self._seed

    @property
    def default_shots(self) -> int:
        """Shots of a PUB that names none."""
        return self._default_shots

    def with_seed(self, seed: int | None) -> AerSampler:
        """The same sampler (same simulator) with another seed."""
        return AerSampler(self.simulator, seed, self._default_shots)

    def run(self, pubs, *, shots: int | None = None):
        """Sample ``pubs`` (as qiskit-aer's ``SamplerV2.run``)."""
        aer = SamplerV2.from_backend(self.simulator, seed=self._seed,
                                     default_shots=self._default_shots)
        return aer.run(pubs, shots=shots)


@validates(make_simulator=CallableC("a callable method -> AerSimulator"),
           noisy=Instance((bool, np.bool_), "bool"), seed=[Interval(int), None],
           default_shots=Shots(), options=[Instance(dict, "a dict of Aer options"), None])
class AdaptiveSampler(BaseSamplerV2):
    """A seeded Aer sampler whose Aer method and options follow each PUB.

    PUBs of one ``run`` call are grouped by their shots (as qiskit-aer's ``SamplerV2`` does),
    then by the options :func:`aer_options` gives them (their active qubits and shots); each
    group runs as one job of qiskit-aer's public ``SamplerV2.from_backend(simulator, seed=...)``
    on a simulator built by ``make_simulator(method)`` with those options
    (``AerSimulator.set_options``), then ``options`` (the caller's overrides) on top. Within a
    shot count the first group runs with the sampler's seed, every other group with a seed
    derived from it, so runs are reproducible and groups draw independent shots.

    Parameters
    ----------
    make_simulator : callable
        ``make_simulator(method: str) -> AerSimulator`` carrying the target's noise.
    noisy : bool
        Whether those simulators carry noise.
    seed : int or None
    default_shots : int
    options : dict or None
        Aer options applied to every group after the chosen ones (e.g.
        ``{"max_parallel_threads": 1}``); a ``method`` key fixes the method.

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> qc = QuantumCircuit(2)
    >>> _ = qc.h(0)
    >>> _ = qc.cx(0, 1)
    >>> _ = qc.measure_all()
    >>> sampler = AdaptiveSampler(NoiselessSimulators(seed=1), noisy=False, seed=1)
    >>> sampler.choose(qc, shots=100)["method"]
    'automatic'
    >>> sorted(sampler.run([qc], shots=100).result()[0].data.meas.get_counts())
    ['00', '11']
    """

    def __init__(self, make_simulator: Callable[[str], AerSimulator], noisy: bool,
                 seed: int | None = None, default_shots: int = 1024,
                 options: dict | None = None):
        self._make_simulator = make_simulator
        self._noisy = bool(noisy)
        self._seed = seed
        self._default_shots = int(default_shots)
        self._overrides = dict(options or {})
        self._simulators: dict = {}
        # exact noisy distributions for few-qubit PUBs (.noisy_exact)
        self._exact = ExactRoute(make_simulator, self._noisy)

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_simulators"] = {}  # a cache of built simulators: rebuilt, not pickled
        return state

    @property
    def seed(self) -> int | None:
        """The seed of the first group of every shot count (None: Aer draws its own)."""
        return self._seed

    @property
    def default_shots(self) -> int:
        """Shots of a PUB that names none."""
        return self._default_shots

    @property
    def options(self) -> dict:
        """The caller's Aer overrides (a copy)."""
        return dict(self._overrides)

    def with_seed(self, seed: int | None) -> AdaptiveSampler:
        """The same sampler (sharing its simulators) with another seed."""
        out = AdaptiveSampler(self._make_simulator, self._noisy, seed, self._default_shots,
                              self._overrides)
        out._simulators = self._simulators
        out._exact = self._exact  # noisy_exact: one compiled program per template
        return out

    def choose(self, circuit: QuantumCircuit, shots: int, rows: int = 1) -> dict:
        """The Aer options a PUB of ``circuit`` at ``shots`` shots runs with (overrides applied).

        Parameters
        ----------
        circuit : QuantumCircuit
        shots : int
        rows : int
            Parameter rows of the PUB.

        Returns
        -------
        dict
        """
        weight = (circuit.metadata or {}).get(HAMMING_WEIGHT_KEY)
        a = active_qubits(circuit)
        options = {**aer_options(a, shots, self._noisy, weight, rows), **self._overrides}
        if "method" not in self._overrides and not _fits(a, options["method"]):
            bond = mps_bond_bound(circuit)  # too wide for a dense state: bounded entanglement?
            if bond is not None and bond <= MPS_MAX_BOND:
                options = {**options, "method": "matrix_product_state",
                           "max_parallel_threads": 1}
                options.pop("max_parallel_shots", None)
        check_memory(a, options["method"], "SamplerEngine (Aer SamplerV2)", circuit)
        return options

    def simulator(self, options: dict) -> AerSimulator:
        """The simulator a group with these Aer ``options`` runs on (built once, then kept)."""
        key = tuple(sorted(options.items()))
        if key not in self._simulators:
            sim = self._make_simulator(options["method"])
            sim.set_options(**{k: v for k, v in options.items() if k != "method"})
            self._simulators[key] = sim
        return self._simulators[key]

    def run(self, pubs, *, shots: int | None = None) -> LocalJob:
        """Sample ``pubs``: a job whose result holds one ``SamplerPubResult`` per PUB."""
        shots = self._default_shots if shots is None else shots
        coerced = [SamplerPub.coerce(pub, shots) for pub in pubs]
        return LocalJob(self._run, coerced)

    def _run(self, pubs: list[SamplerPub]) -> PrimitiveResult:
        out: list = [None] * len(pubs)
        exact = self._exact.take(pubs, out, self._seed, self._overrides)  # noisy_exact
        for shots, members in _by_shots(pubs).items():
            groups: dict = {}
            for i in members:
                if i in exact:  # noisy_exact: drawn from the exact distribution
                    continue
                opts = self.choose(pubs[i].circuit, shots, max(pubs[i].parameter_values.size, 1))
                groups.setdefault(tuple(sorted(opts.items())), (opts, []))[1].append(i)
            for g, (opts, idx) in enumerate(groups.values()):
                seed = self._seed
                if g and seed is not None:
                    seed = derived_seed(seed, 7919, g)
                aer = SamplerV2.from_backend(self.simulator(opts), seed=seed,
                                             default_shots=shots)
                results = aer.run([pubs[i] for i in idx], shots=shots).result()
                for i, res in zip(idx, results, strict=True):
                    out[i] = res
        return PrimitiveResult(out, metadata={"version": 2})


@validates(sampler=Unchecked("any sampler: None unless it is a fixed-method Aer sampler"))
def sampler_method(sampler) -> str | None:
    """The Aer method of a fixed-method Aer sampler, read through public API (None otherwise).

    Parameters
    ----------
    sampler : BaseSamplerV2

    Returns
    -------
    str or None
        ``AerSampler``: its simulator's ``method``; qiskit-aer's ``SamplerV2``: the ``method``
        of its ``backend_options`` (``"automatic"`` when unset); anything else (an
        :class:`AdaptiveSampler`, which checks each PUB itself, or a provider's): None.

    Examples
    --------
    >>> sampler_method(AerSampler(AerSimulator(method="density_matrix")))
    'density_matrix'
    >>> sampler_method(SamplerV2()), sampler_method(object()) is None
    ('automatic', True)
    """
    if isinstance(sampler, AerSampler):
        return str(sampler.simulator.options.method)
    if isinstance(sampler, SamplerV2):
        return str(sampler.options.backend_options.get("method", "automatic"))
    return None


@validates(seed=[Interval(int), None])
class NoiselessSimulators:
    """``make_simulator`` of a noiseless :class:`AdaptiveSampler`: ``AerSimulator(method=m)``
    seeded (a module-level class, so samplers pickle).

    Parameters
    ----------
    seed : int or None
        Hashed into ``seed_simulator`` (:func:`~qdensity.hardware.aer_sampling.aer_seed`).

    Examples
    --------
    >>> sim = NoiselessSimulators(seed=3)("statevector")
    >>> sim.options.method, sim.options.noise_model is None
    ('statevector', True)
    """

    def __init__(self, seed: int | None = None):
        self.seed = seed

    def __call__(self, method: str) -> AerSimulator:
        return AerSimulator(method=method, seed_simulator=aer_seed(self.seed))
