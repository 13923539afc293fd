"""A :class:`~qdensity.execution.engines.SamplerEngine` on a provider's runtime sampler.

The runtime's sampler and its options are built by :mod:`qdensity.hardware.runtime`; this
module pairs it with the device's preset pass manager, so every template is transpiled for the
device once and checked against it before any job is submitted.
"""

from __future__ import annotations

from qdensity.execution.sampler.engine import SamplerEngine, ShotLedger
from qdensity.hardware.runtime import require_runtime, runtime_sampler
from qdensity.validation import SeedLike, seed_int

__all__ = ["runtime_engine"]


def runtime_engine(
    backend,
    *,
    mode=None,
    optimization_level: int = 1,
    seed: SeedLike = None,
    ledger: ShotLedger | None = None,
    default_shots: int = 1024,
    **knobs,
) -> SamplerEngine:
    """A :class:`SamplerEngine` on a provider's runtime sampler, transpiling for ``backend``.

    Parameters
    ----------
    backend : qiskit.providers.BackendV2
        The device (a ``qiskit_ibm_runtime.IBMBackend`` or a fake backend; for a snapshot
        target, ``target.backend``).
    mode : qiskit_ibm_runtime.Batch or Session, optional
        Groups the engine's jobs; default: ``backend`` (one job per run).
    optimization_level : int
        Of ``generate_preset_pass_manager``.
    seed : int or numpy.random.Generator, optional
        Seeds transpilation and (local testing mode) simulation.
    ledger : ShotLedger, optional
    default_shots : int
        Shots per row for jobs that do not say.
    **knobs
        ``dynamical_decoupling``, ``twirling``, ``options``: as :func:`runtime_options`.

    Returns
    -------
    SamplerEngine
        Its ``sampler`` is the runtime's; circuits are checked against ``backend`` before any
        job is submitted.

    Examples
    --------
    A fake backend runs in the runtime's local testing mode; a job wider than the device is
    refused before anything is submitted:

    >>> from qiskit import QuantumCircuit
    >>> from qiskit_ibm_runtime.fake_provider import FakeManilaV2
    >>> from qdensity.execution.plans import probabilities_plan
    >>> from qdensity.execution.sampler.runtime import runtime_engine
    >>> engine = runtime_engine(FakeManilaV2(), seed=1, default_shots=100)
    >>> type(engine.sampler).__name__, engine.default_shots
    ('SamplerV2', 100)
    >>> probabilities_plan(QuantumCircuit(6), [], shots=10).run(engine)
    Traceback (most recent call last):
    ValueError: job 'probabilities' needs 6 qubits but device 'fake_manila' has 5; ...
    """
    require_runtime()
    from qiskit.providers import BackendV2
    from qiskit.transpiler import generate_preset_pass_manager

    if not isinstance(backend, BackendV2):
        raise TypeError(f"backend must be a qiskit BackendV2, got {type(backend).__name__}")
    seed_value = seed_int(seed)
    sampler = runtime_sampler(backend if mode is None else mode, shots=default_shots,
                              seed=seed_value, **knobs)
    pm = generate_preset_pass_manager(optimization_level=optimization_level, backend=backend,
                                      seed_transpiler=seed_value)
    return SamplerEngine(sampler=sampler, transpiler=pm.run, ledger=ledger,
                         default_shots=default_shots)
