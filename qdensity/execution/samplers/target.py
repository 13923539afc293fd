"""A hardware target's sampler: :func:`target_sampler` builds the Aer sampler that runs
circuits on a :class:`~qdensity.hardware.targets.HardwareTarget`'s simulator (its noise,
coupling and seed).

The target (one layer below, :mod:`qdensity.hardware`) knows its device: native gates, noise
model, ``AerSimulator``; the samplers that run on it live here, with the other samplers.
"""

from __future__ import annotations

import numpy as np
from qiskit_aer import AerSimulator

from qdensity.execution.samplers.aer import AdaptiveSampler, AerSampler, NoiselessSimulators
from qdensity.hardware.aer_sampling import FAST_SAMPLER_OPTIONS, aer_seed
from qdensity.hardware.targets import SIMULATION_METHODS, HardwareTarget
from qdensity.validation import (
    Instance,
    Options,
    Seed,
    SeedLike,
    Shots,
    seed_int,
    validates,
)

__all__ = ["target_sampler"]

#: ``method`` values of :func:`target_sampler`: ``"auto"`` or a fixed Aer method.
SAMPLER_METHODS = ("auto", *SIMULATION_METHODS)


class TargetSimulators:
    """``make_simulator`` of a hardware target's :class:`AdaptiveSampler`: the target's Aer
    simulator for a method, on ``device`` with ``seed`` (picklable, so the sampler is).

    Parameters
    ----------
    target : qdensity.hardware.targets.HardwareTarget
    device : {"CPU", "GPU"}
    seed : int or None
    """

    def __init__(self, target: HardwareTarget, device: str, seed: int | None):
        self.target, self.device, self.seed = target, device, seed

    def __call__(self, method: str) -> AerSimulator:
        return self.target.simulator(method=method, device=self.device, seed=self.seed)


@validates(
    target=Instance(HardwareTarget), seed=Seed(),
    shots=[Shots(), None], method=Options(SAMPLER_METHODS),
    device=Options(("CPU", "GPU")), fast=Instance((bool, np.bool_), "bool"),
    options=[Instance(dict, "a dict of Aer options"), None],
)
def target_sampler(
    target: HardwareTarget,
    seed: SeedLike = None,
    shots: int | None = None,
    method: str = "auto",
    device: str = "CPU",
    fast: bool = True,
    options: dict | None = None,
) -> AdaptiveSampler | AerSampler:
    """A seeded Aer sampler running on ``target.simulator`` (noise, coupling, seed).

    Parameters
    ----------
    target : HardwareTarget
        The device (:func:`~qdensity.hardware.targets.get_target`).
    seed : int, numpy.random.Generator or None
        Seed of every run (the sampler's ``seed``, which Aer uses as ``seed_simulator``);
        None uses the target's seed. The same seed and PUBs give the same counts.
    shots : int or None
        Default shots per PUB; None means 1024.
    method : {"auto", "automatic", "statevector", "density_matrix", "matrix_product_state"}
        ``"auto"``: an :class:`~qdensity.execution.samplers.aer.AdaptiveSampler`, choosing
        per PUB by the qubits it acts on and its shots (noisy: the exact noisy distribution
        for a few qubits from :func:`~qdensity.execution.samplers.noisy_exact.exact_from`
        shots a row, else density matrix up to 12 active qubits from the measured crossover,
        8 to 96 shots up to 8 qubits; otherwise one trajectory per shot; the table is in
        :mod:`~qdensity.hardware.aer_sampling`). Any other value fixes Aer's method, as
        ``HardwareTarget.simulator``.
    device : {"CPU", "GPU"}
        As ``HardwareTarget.simulator``.
    fast : bool
        With a fixed ``method``: apply ``FAST_SAMPLER_OPTIONS`` (parameter rows bound
        inside Aer, all threads; never shot branching, which samples wrong distributions
        with noise in qiskit-aer 0.18.2). Counts repeat for a seed, not across it.
    options : dict or None
        Aer options set last, overriding the chosen ones (``{"max_parallel_threads": 1}``).

    Returns
    -------
    AdaptiveSampler or AerSampler
        ``BaseSamplerV2`` implementations on qiskit-aer's public ``SamplerV2``
        (:mod:`qdensity.execution.samplers.aer`): an :class:`AdaptiveSampler` for
        ``method="auto"``, an :class:`AerSampler` on ``target.simulator`` otherwise. Aer
        primitives do not transpile: submit circuits from ``target.transpile``.

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> from qdensity.hardware.targets import get_target
    >>> tgt = get_target("ring", 3, seed=2)
    >>> qc = QuantumCircuit(3)
    >>> _ = qc.h(0)
    >>> _ = qc.measure_all()
    >>> result = target_sampler(tgt, seed=5, shots=200).run([tgt.transpile(qc)]).result()
    >>> result[0].data.meas.num_shots
    200
    """
    sim_seed = target.seed if seed is None else seed_int(seed)
    default_shots = 1024 if shots is None else int(shots)
    if method == "auto":
        make = TargetSimulators(target, device, sim_seed)
        return AdaptiveSampler(make, target.is_noisy, seed=aer_seed(sim_seed),
                               default_shots=default_shots, options=options)
    sim = target.simulator(method=method, device=device, seed=sim_seed)
    if fast:
        sim.set_options(**FAST_SAMPLER_OPTIONS)
    if options:
        sim.set_options(**options)
    return AerSampler(sim, seed=aer_seed(sim_seed), default_shots=default_shots)


def engine_sampler(target: HardwareTarget | None, seed: int | None) -> AdaptiveSampler:
    """A sampler engine's own sampler: the target's (:func:`target_sampler`), or noiseless Aer
    choosing its method per PUB when there is no target."""
    if target is not None:
        return target_sampler(target, seed=seed)
    return AdaptiveSampler(NoiselessSimulators(seed), False, seed=aer_seed(seed))
