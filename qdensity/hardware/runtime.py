"""A hardware provider's runtime client behind :class:`qdensity.execution.engines.SamplerEngine`.

qdensity talks to hardware through the ``BaseSamplerV2`` interface only (docs/design.md,
"The spine", step 5), so a provider's primitive plugs into
:class:`~qdensity.execution.engines.SamplerEngine` unchanged::

    from qiskit.transpiler import generate_preset_pass_manager
    from qiskit_ibm_runtime import SamplerV2
    engine = SamplerEngine(sampler=SamplerV2(mode=backend),
                           transpiler=generate_preset_pass_manager(backend=backend).run)

This module builds that pair for IBM's ``qiskit-ibm-runtime`` (the optional extra ``ibm``):
:func:`runtime_sampler` turns qdensity's few knobs (shots, seed, dynamical decoupling,
twirling, any other runtime option) into the runtime's ``SamplerOptions``, validated when the
sampler is made, so options the runtime rejects raise ``ValueError`` before any job is
submitted; :func:`qdensity.execution.sampler.runtime.runtime_engine` adds the device's preset pass
manager. ``mode`` is a backend
(one job per :meth:`SamplerEngine.run`), or a ``qiskit_ibm_runtime.Batch`` that groups the many
jobs of a training run or an experiment for the provider's scheduler.

With a fake backend of ``qiskit_ibm_runtime.fake_provider`` (a calibrated device snapshot, see
:mod:`qdensity.hardware.snapshots`) the runtime runs in *local testing mode*: jobs are simulated
by Aer with the snapshot's noise; ``default_shots`` and the seed are honoured, while dynamical
decoupling and twirling are accepted, validated and carried in the options (they take effect on
hardware; locally the runtime warns that they have no effect).
"""

from __future__ import annotations

import importlib.util
import warnings
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from qiskit.primitives import BaseSamplerV2

from qdensity.hardware.aer_sampling import aer_seed
from qdensity.validation import SeedLike, check_positive_int, seed_int

if TYPE_CHECKING:
    from qiskit.primitives import BaseSamplerV2

__all__ = ["runtime_available", "runtime_options", "runtime_sampler", "require_runtime"]

_INSTALL = "pip install 'qdensity[ibm]' (or pip install qiskit-ibm-runtime)"
_DD_SEQUENCES = ("XX", "XpXm", "XY4")


def runtime_available() -> bool:
    """Whether ``qiskit-ibm-runtime`` (the ``ibm`` extra) is installed.

    Returns
    -------
    bool

    Examples
    --------
    >>> from qdensity.hardware.snapshots import snapshots_available
    >>> runtime_available() == snapshots_available()  # both: the ibm extra installed
    True
    """
    return importlib.util.find_spec("qiskit_ibm_runtime") is not None


def require_runtime() -> None:
    """Raise ``ValueError`` naming what to install when qiskit-ibm-runtime is missing.

    Examples
    --------
    >>> require_runtime() if runtime_available() else None  # raises only without the extra
    """
    if not runtime_available():
        raise ValueError(f"the provider's runtime client needs qiskit-ibm-runtime; install the "
                         f"optional extra: {_INSTALL}")


def runtime_options(
    *,
    shots: int | None = None,
    seed: SeedLike = None,
    dynamical_decoupling: bool | str | None = None,
    twirling: bool | None = None,
    options: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """The runtime ``SamplerOptions`` dictionary for qdensity's knobs.

    Parameters
    ----------
    shots : int, optional
        ``default_shots``: shots per parameter row of PUBs that do not say (qdensity's plans
        always say).
    seed : int or numpy.random.Generator, optional
        ``simulator.seed_simulator`` (honoured in local testing mode, ignored on hardware).
    dynamical_decoupling : bool or {"XX", "XpXm", "XY4"}, optional
        Enable dynamical decoupling, with a sequence type when a string is given.
    twirling : bool, optional
        Pauli-twirl two-qubit gates and measurements (``enable_gates``, ``enable_measure``).
    options : mapping, optional
        Further runtime options, merged last (``{"execution": {"init_qubits": True}}``, ...).

    Returns
    -------
    dict

    Examples
    --------
    >>> runtime_options(shots=100, dynamical_decoupling="XY4")
    {'default_shots': 100, 'dynamical_decoupling': {'enable': True, 'sequence_type': 'XY4'}}
    """
    out: dict[str, Any] = {}
    if shots is not None:
        out["default_shots"] = check_positive_int(shots, "shots")
    if seed is not None:
        out["simulator"] = {"seed_simulator": aer_seed(seed_int(seed))}
    if dynamical_decoupling is not None:
        if isinstance(dynamical_decoupling, str):
            if dynamical_decoupling not in _DD_SEQUENCES:
                raise ValueError(f"dynamical_decoupling must be a bool or one of "
                                 f"{list(_DD_SEQUENCES)}, got {dynamical_decoupling!r}")
            out["dynamical_decoupling"] = {"enable": True,
                                           "sequence_type": dynamical_decoupling}
        elif isinstance(dynamical_decoupling, bool):
            out["dynamical_decoupling"] = {"enable": dynamical_decoupling}
        else:
            raise TypeError(f"dynamical_decoupling must be a bool or one of "
                            f"{list(_DD_SEQUENCES)}, got {dynamical_decoupling!r}")
    if twirling is not None:
        if not isinstance(twirling, bool):
            raise TypeError(f"twirling must be a bool, got {twirling!r}")
        out["twirling"] = {"enable_gates": twirling, "enable_measure": twirling}
    if options is not None:
        if not isinstance(options, Mapping):
            raise TypeError(f"options must be a mapping of runtime options, got "
                            f"{type(options).__name__}")
        for key, val in options.items():
            if isinstance(val, Mapping) and isinstance(out.get(key), dict):
                out[key] = {**out[key], **val}
            else:
                out[key] = val
    return out


def runtime_sampler(mode, **knobs) -> BaseSamplerV2:
    """A ``qiskit_ibm_runtime.SamplerV2`` with validated options.

    Parameters
    ----------
    mode : BackendV2, qiskit_ibm_runtime.Batch or qiskit_ibm_runtime.Session
        A backend (a fake backend runs in local testing mode), or a batch grouping many jobs.
    **knobs
        ``shots``, ``seed``, ``dynamical_decoupling``, ``twirling``, ``options``: as
        :func:`runtime_options`.

    Returns
    -------
    qiskit_ibm_runtime.SamplerV2
        A ``BaseSamplerV2``.

    Raises
    ------
    ValueError
        Without the ``ibm`` extra, or for options the runtime rejects (its validation message
        is kept), before any job is submitted.

    Examples
    --------
    A fake backend runs in the runtime's local testing mode (needs the ``ibm`` extra):

    >>> from qiskit.providers.fake_provider import GenericBackendV2
    >>> runtime_sampler(GenericBackendV2(2, seed=1), shots=100).options.default_shots
    100
    """
    require_runtime()
    from qiskit_ibm_runtime import SamplerV2

    opts = runtime_options(**knobs)
    with warnings.catch_warnings():
        # qiskit-ibm-runtime 0.50 deprecates SamplerV2 in favour of a client-side Sampler that
        # is not yet a BaseSamplerV2; SamplerV2 stays the documented V2 primitive until then.
        warnings.simplefilter("ignore", DeprecationWarning)
        try:
            return SamplerV2(mode=mode, options=opts)
        except ValueError as exc:  # pydantic's ValidationError is a ValueError
            raise ValueError(f"options {opts} are rejected by the runtime sampler: {exc}") from exc
