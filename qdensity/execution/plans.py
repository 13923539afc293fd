"""Plans: every quantum question compiled to circuits, parameter rows, shots and post-processing.

A :class:`Plan` is a list of :class:`CircuitJob` s (one measured template, its parameter rows,
shots per row or ``None`` for exact) plus a post-processing function from the engines'
:class:`JobResult` s to the answer. The number of circuits and shots a question costs is read
off its plan (docs/design.md, "The spine", step 4): this is how Table 1 is checked and how
shot ledgers stay honest.

Measured templates follow one convention: qubit ``j`` is measured into clbit ``j`` of one
classical register, so an outcome is the integer ``sum_j b_j 2^j`` and outcome probabilities
are dense arrays of length ``2**num_clbits``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Generic, TypeVar, cast

import numpy as np
from qiskit.circuit import QuantumCircuit
from qiskit.quantum_info import SparsePauliOp

from qdensity.analysis.pauli import ZStringTable
from qdensity.circuits.measure import measured
from qdensity.execution.intervals import shot_mean, wilson_standard_error
from qdensity.execution.job_results import JobResult, bits_to_probabilities, unary_frequencies
from qdensity.execution.observables import basis_rotation, check_observable
from qdensity.validation import (
    MAX_DENSE_ENTRIES,
    MAX_PLAN_SHOTS,
    MAX_SHOTS,
    Array,
    CallableC,
    Circuit,
    Instance,
    Interval,
    Observable,
    SequenceOf,
    as_parameter_rows,
    check_engine,
    check_positive_int,
    check_width,
    validates,
)

__all__ = [
    "CircuitJob", "JobResult", "Plan", "Estimate", "measured", "expectation_plan",
    "probabilities_plan", "postselect_hamming_weight", "bits_to_probabilities", "unary_frequencies",
]
_T = TypeVar("_T")  # what a plan's post-processing returns


@validates(
    circuit=Circuit(), values=[Array(ndim=(1, 2), min_size=0, max_size=MAX_DENSE_ENTRIES), None],
    shots=[Interval(int, 1, MAX_SHOTS), None], label=Instance(str),
)
@dataclass(frozen=True)
class CircuitJob:
    """One measured circuit template and the parameter rows it runs with.

    Attributes
    ----------
    circuit : QuantumCircuit
        Measured template (qubit ``j`` -> clbit ``j``); parameters in ``circuit.parameters``.
    values : numpy.ndarray, shape (rows, P)
        One row per execution.
    shots : int or None
        Shots per row; ``None`` asks for exact probabilities.
    label : str
        What the job is for (ledger key).

    Examples
    --------
    >>> job = CircuitJob(measured(QuantumCircuit(2)), np.zeros((3, 0)), shots=100)  # 3 rows
    >>> job.rows, job.circuit.num_clbits
    (3, 2)
    """

    circuit: QuantumCircuit
    values: np.ndarray
    shots: int | None = None
    label: str = ""

    def __post_init__(self) -> None:
        self._check_rows(self.circuit.num_parameters)
        if self.circuit.num_clbits == 0:
            raise ValueError("a CircuitJob circuit must measure into classical bits")

    def _check_rows(self, num_parameters: int) -> None:
        """``values`` as ``(rows, num_parameters)`` rows, at least one; ``shots`` bounded."""
        object.__setattr__(self, "values", checked_rows(self.values, num_parameters,
                                                        self.shots))

    @property
    def rows(self) -> int:
        """Number of parameter rows (circuit executions)."""
        return int(self.values.shape[0])

    @property
    def num_qubits(self) -> int:
        """Width of the template (``circuit.num_qubits``)."""
        return self.circuit.num_qubits

    def with_shots(self, shots: int | None) -> CircuitJob:
        """The same job with ``shots`` per row."""
        return replace(self, shots=shots)


def checked_rows(values, num_parameters: int, shots: int | None) -> np.ndarray:
    """:class:`CircuitJob`'s checks of its rows: ``values`` as ``(rows, num_parameters)``
    rows, at least one, and ``shots`` bounded by the rows (the measured bits of every shot
    are held in memory)."""
    vals = as_parameter_rows(values, num_parameters, "values")
    if vals.shape[0] == 0:
        raise ValueError("values must have at least one parameter row, got shape "
                         f"{vals.shape} (a job with zero rows runs nothing)")
    if shots is not None:
        check_positive_int(shots, "shots", maximum=MAX_DENSE_ENTRIES // vals.shape[0],
                           why=f"{vals.shape[0]} rows x shots <= {MAX_DENSE_ENTRIES}")
    return vals


@validates(value=Array(ndim=None, min_size=0, finite=False),
           standard_error=Array(ndim=None, min_size=0, finite=False))
@dataclass
class Estimate:
    """A value with its standard error (zero for exact evaluations).

    Attributes
    ----------
    value : numpy.ndarray
    standard_error : numpy.ndarray
        Same shape as ``value``.

    Examples
    --------
    >>> value, standard_error = Estimate(np.array([0.5]), np.array([0.1]))  # unpacks as a pair
    >>> float(standard_error[0])
    0.1
    """

    value: np.ndarray
    standard_error: np.ndarray

    def __iter__(self):
        return iter((self.value, self.standard_error))


@validates(
    jobs=SequenceOf(Instance(CircuitJob), min_len=0), meta=Instance(dict),
    postprocess=CallableC('a callable results -> answer'), description=Instance(str),
)
@dataclass
class Plan(Generic[_T]):
    """Jobs plus the post-processing that turns their results into an answer (of type ``_T``).

    Attributes
    ----------
    jobs : list of CircuitJob
    postprocess : callable
        ``postprocess(results: list[JobResult]) -> answer``, results in job order.
    description : str

    Examples
    --------
    >>> plan = probabilities_plan(QuantumCircuit(1), np.zeros((2, 0)), shots=50)  # 2 rows
    >>> plan.num_templates, plan.num_circuits, plan.total_shots
    (1, 2, 100)
    """

    jobs: list[CircuitJob]
    postprocess: Callable[[list[JobResult]], _T]
    description: str = ""
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        total = self.total_shots
        if total is not None and total > MAX_PLAN_SHOTS:  # each job is bounded; so is the sum
            raise ValueError(f"Plan: jobs must ask for at most {MAX_PLAN_SHOTS} shots in total "
                             f"(days of sampling), got {total} (rows x shots summed over "
                             f"{len(self.jobs)} jobs); split the plan or use fewer shots")

    @property
    def num_templates(self) -> int:
        """Distinct circuit templates (one PUB each)."""
        return len(self.jobs)

    @property
    def num_circuits(self) -> int:
        """Distinct circuit executions: the sum of parameter rows over the jobs."""
        return int(sum(job.rows for job in self.jobs))

    @property
    def total_shots(self) -> int | None:
        """Shots the plan spends, or None if any job is exact."""
        if any(job.shots is None for job in self.jobs):
            return None
        return int(sum(job.rows * cast(int, job.shots) for job in self.jobs))

    def with_shots(self, shots: int | None) -> Plan[_T]:
        """The same plan with every job's shots per row set to ``shots``."""
        if shots is not None:
            check_positive_int(shots, "shots")
        return replace(self, jobs=[job.with_shots(shots) for job in self.jobs])

    def run(self, engine) -> _T:
        """Execute on ``engine`` (anything with ``run(jobs) -> list[JobResult]``); post-process."""
        results = check_engine(engine).run(self.jobs)
        return self.postprocess(results)

    @staticmethod
    def combine(plans: Sequence[Plan], description: str = "") -> Plan[list]:
        """One plan running several; its post-processing returns the list of their answers."""
        plans = list(plans)
        bounds = np.cumsum([0] + [len(p.jobs) for p in plans])
        post = partial(_combined_post, plans, bounds)
        jobs = [job for p in plans for job in p.jobs]
        return Plan(jobs, post, description or "; ".join(p.description for p in plans))


# Post-processing functions live at module level and are bound with functools.partial, so that
# plans pickle (joblib, multiprocessing and optuna workers ship them).
def _combined_post(plans, bounds, results: list[JobResult]) -> list:
    return [p.postprocess(results[a:b]) for p, a, b in zip(plans, bounds[:-1], bounds[1:],
                                                           strict=True)]


def _expectation_post(num_rows, constant, diagonals, results: list[JobResult]) -> Estimate:
    """Sum of the groups' estimates (module level, so plans pickle)."""
    value = np.full(num_rows, constant)
    var = np.zeros(num_rows)
    for res, table in zip(results, diagonals, strict=True):
        if res.bits is not None:  # parities of the measured bits, never 2**n
            per_shot = np.stack([table.on_bits(r)[:, 0] for r in res.bits])
            mean, se = shot_mean(per_shot, table.value_range()[0], weights=res.weights,
                                 effective_shots=res.effective_shots,
                                 linearisations=res.readout)
            value += mean
            var += se**2
            continue
        diag = table.dense()[:, 0]
        mean = res.probabilities @ diag
        value += mean
        if res.shots is not None:
            second = res.probabilities @ diag**2
            width = float(diag.max() - diag.min())
            var += wilson_standard_error(second - mean**2, res.shots, width) ** 2
    return Estimate(value, np.sqrt(var))


def _first_result(results: list[JobResult]) -> JobResult:
    return results[0]


@validates(
    circuit=Circuit(min_qubits=1), observable=Observable(),
    values=[Array(ndim=(1, 2), min_size=0, max_size=MAX_DENSE_ENTRIES), None],
    shots=[Interval(int, 1, MAX_SHOTS), None], label=Instance(str),
)
def expectation_plan(
    circuit: QuantumCircuit, observable: SparsePauliOp, values, *, shots: int | None = None,
    label: str = "expectation",
) -> Plan[Estimate]:
    """Plan for ``<psi(values)| H |psi(values)>`` by measuring qubit-wise commuting groups.

    Each group of ``H``'s Pauli terms is one template (basis rotation then measurement) run
    with all parameter rows in one job. Exact when ``shots`` is None.

    Parameters
    ----------
    circuit : QuantumCircuit
        Unmeasured state-preparation circuit with ``P`` free parameters.
    observable : SparsePauliOp
        ``H`` on ``circuit.num_qubits`` qubits, real coefficients.
    values : array_like, shape (rows, P) or (P,)
    shots : int, optional
        Shots per row per group.
    label : str

    Returns
    -------
    Plan
        Post-processing returns an :class:`Estimate` with ``value`` and ``standard_error`` of
        shape (rows,).

    Examples
    --------
    >>> from qiskit.circuit import Parameter
    >>> from qdensity.execution.engines import ExactEngine
    >>> qc = QuantumCircuit(1); _ = qc.ry(Parameter("t"), 0)
    >>> est = expectation_plan(qc, SparsePauliOp("Z"), [[0.0], [np.pi]]).run(ExactEngine())
    >>> est.value.round(12).tolist(), est.standard_error.tolist()  # cos t, exact
    ([1.0, -1.0], [0.0, 0.0])
    """
    observable = check_observable(observable, circuit.num_qubits).simplify()
    vals = as_parameter_rows(values, circuit.num_parameters)
    jobs: list[CircuitJob] = []
    diagonals: list[ZStringTable] = []
    constant = 0.0
    for group in observable.group_commuting(qubit_wise=True):
        ident = ~(group.paulis.x.any(axis=1) | group.paulis.z.any(axis=1))
        constant += float(np.real(group.coeffs[ident].sum()))
        group = SparsePauliOp(group.paulis[~ident], group.coeffs[~ident]) if ident.any() else group
        if len(group.paulis) == 0 or not (~ident).any():
            continue
        rot, images = basis_rotation(group.paulis)
        template = measured(circuit.compose(rot))
        jobs.append(CircuitJob(template, vals, shots, f"{label}[{len(jobs)}]"))
        coeffs = np.real(np.asarray(group.coeffs) * (-1j) ** images.phase)
        diagonals.append(ZStringTable(images.z, coeffs[:, None]))

    post = partial(_expectation_post, vals.shape[0], constant, diagonals)
    return Plan(jobs, post, f"<H> of {circuit.name} ({len(jobs)} groups)")


@validates(
    circuit=Circuit(min_qubits=1),
    values=[Array(ndim=(1, 2), min_size=0, max_size=MAX_DENSE_ENTRIES), None],
    shots=[Interval(int, 1, MAX_SHOTS), None], label=Instance(str), inplace=Instance(bool),
)
def probabilities_plan(
    circuit: QuantumCircuit, values, *, shots: int | None = None, label: str = "probabilities",
    inplace: bool = False,
) -> Plan[JobResult]:
    """Plan for the computational-basis outcome distribution of ``circuit``.

    Parameters
    ----------
    circuit : QuantumCircuit
        Unmeasured circuit with ``P`` free parameters.
    values : array_like, shape (rows, P)
    shots : int, optional
    label : str
        The job's label.
    inplace : bool
        Measure ``circuit`` itself (a copy the caller just made and gives away, as
        :func:`measured` ``(..., inplace=True)``) instead of a copy of it.

    Returns
    -------
    Plan
        Post-processing returns the :class:`JobResult`: exact ``probabilities`` of shape
        (rows, 2**n) (at most 24 qubits), or, sampled, the measured ``bits`` at any width
        (unary frequencies and parities are read off them; the dense ``probabilities`` only
        up to 24 qubits).

    Examples
    --------
    >>> from qdensity.execution.engines import ExactEngine
    >>> qc = QuantumCircuit(2); _ = qc.h(0)
    >>> probabilities_plan(qc, []).run(ExactEngine()).probabilities.round(12).tolist()
    [[0.5, 0.5, 0.0, 0.0]]
    """
    if shots is None:
        check_width(circuit.num_qubits, engine="probabilities_plan without shots (dense "
                    "(rows, 2**n) outcome probabilities)", alternative="the unary engine for "
                    "RBS circuits, or shots= (sampled estimates from the measured bits)")
    vals = as_parameter_rows(values, circuit.num_parameters)
    job = CircuitJob(measured(circuit, inplace=inplace), vals, shots, label)
    return Plan([job], _first_result, f"P(b) of {circuit.name}")


def postselect_hamming_weight(probabilities, weight: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Keep only outcomes of a given Hamming weight and renormalise them (documented here).

    For unary circuits every ideal outcome has weight 1; noise leaks weight elsewhere. The
    post-selected distribution is ``p(b) / kept`` on weight-``weight`` outcomes.

    Parameters
    ----------
    probabilities : numpy.ndarray, shape (rows, 2**m)
    weight : int

    Returns
    -------
    (numpy.ndarray (rows, 2**m), numpy.ndarray (rows,))
        The post-selected distributions (zero elsewhere) and the kept fraction per row.

    Raises
    ------
    ValueError
        If a row keeps nothing.

    Examples
    --------
    >>> out, kept = postselect_hamming_weight([[0.1, 0.3, 0.6, 0.0]])  # b = 1, 2 have weight 1
    >>> out.round(4).tolist(), kept.round(12).tolist()
    ([[0.0, 0.3333, 0.6667, 0.0]], [0.9])
    """
    probs = np.atleast_2d(np.asarray(probabilities, dtype=float))
    m = int(round(np.log2(probs.shape[1])))
    if 2**m != probs.shape[1]:
        raise ValueError(f"probabilities must have 2**m columns, got {probs.shape[1]}")
    outcomes = np.arange(2**m)
    popcount = np.array([bin(b).count("1") for b in outcomes])
    mask = popcount == weight
    kept = probs[:, mask].sum(axis=1)
    if np.any(kept <= 0):
        raise ValueError(f"rows {np.flatnonzero(kept <= 0).tolist()} keep no outcome of "
                         f"Hamming weight {weight}")
    out = np.where(mask[None, :], probs, 0.0) / kept[:, None]
    return out, kept
