"""Parameter-shift gradients as plans (paper Supp. E, eq. 23).

* Pauli rotations ``exp(-i t r P)`` (rx/ry/rz: r = 1/2; Pauli evolutions: ``r = |c|``): the
  two-term rule ``df/dt = r [f(t + pi/(4r)) - f(t - pi/(4r))]``.
* RBS and FBS (generator eigenvalues {-1, 0, 1}): the four-term rule of eq. 23,
  ``df/dt = [f(t + pi/4) - f(t - pi/4)] - (sqrt(2) - 1)/2 [f(t + pi/2) - f(t - pi/2)]``,
  exact for every input and observable. ``rbs_rule="two_term"`` gives the pi/4 two-term rule,
  exact only when no later gate touches the gate's qubits and the observable is diagonal
  (docs/design.md, "Measured facts"); it is offered to show that fact, not for use.
* Controlled rotations ``crx, cry, crz`` (generator ``|1><1| (x) P/2``, eigenvalues
  {-1/2, 0, 1/2}): the same four-term rule with angles doubled and coefficients halved,
  ``df/dt = [f(t + pi/2) - f(t - pi/2)]/2 - (sqrt(2) - 1)/4 [f(t + pi) - f(t - pi)]``.
  Phase gates ``p``/``cp`` (two eigenvalues one apart) take the two-term rule with r = 1/2;
  any other generator with two eigenvalues, or three equally spaced ones, takes the rule its
  spectrum gives.

A parameter shared by several gates is differentiated occurrence by occurrence: the circuit is
rewritten with one fresh parameter per occurrence, and all shifted rows of that one template go
into one job (one PUB). The circuit count of a gradient is read off its plan.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial

import numpy as np
from qiskit.circuit import Parameter, ParameterVector, QuantumCircuit
from qiskit.quantum_info import PauliList, SparsePauliOp

from qdensity.analysis.gate_registry import GATES
from qdensity.analysis.structure import instruction_generator, parameter_of
from qdensity.execution.intervals import binomial_standard_error
from qdensity.execution.observables import check_observable
from qdensity.execution.plans import (
    Estimate,
    Plan,
    expectation_plan,
    probabilities_plan,
    unary_frequencies,
)
from qdensity.validation import (
    MAX_DENSE_ENTRIES,
    MAX_SHOTS,
    Array,
    Circuit,
    Instance,
    Interval,
    Observable,
    Options,
    SequenceOf,
    as_parameter_rows,
    validates,
)

__all__ = ["ShiftRule", "shift_rules", "parameter_shift_plan", "shift_circuit_count",
           "expand_occurrences"]

_FOUR_TERM = (
    (math.pi / 4, 1.0),
    (-math.pi / 4, -1.0),
    (math.pi / 2, -(math.sqrt(2) - 1) / 2),
    (-math.pi / 2, (math.sqrt(2) - 1) / 2),
)


@dataclass(frozen=True)
class ShiftRule:
    """``df/dt = sum_i coeffs[i] f(t + shifts[i])`` for one gate angle ``t``.

    Examples
    --------
    The two-term rule of ``RY`` (``r = 1/2``) on ``f(t) = cos t``:

    >>> import math
    >>> from qdensity.gradients.shift import ShiftRule
    >>> rule = ShiftRule((math.pi / 2, -math.pi / 2), (0.5, -0.5))
    >>> df = sum(c * math.cos(0.4 + s) for s, c in zip(rule.shifts, rule.coeffs))
    >>> rule.num_terms, math.isclose(df, -math.sin(0.4))
    (2, True)
    """

    shifts: tuple[float, ...]
    coeffs: tuple[float, ...]

    @property
    def num_terms(self) -> int:
        return len(self.shifts)


def _rule_for(inst, circuit: QuantumCircuit, rbs_rule: str) -> ShiftRule:
    name = inst.operation.name
    kind = GATES.get(name)
    if kind is not None and kind.shift_rule == "four_term":
        if rbs_rule == "four_term":
            return ShiftRule(*zip(*_FOUR_TERM, strict=True))
        if rbs_rule == "two_term":
            return ShiftRule((math.pi / 4, -math.pi / 4), (1.0, -1.0))
        raise ValueError(f"rbs_rule must be 'four_term' or 'two_term', got {rbs_rule!r}")
    gen = instruction_generator(inst, circuit).simplify()
    ident = ~(gen.paulis.x.any(axis=1) | gen.paulis.z.any(axis=1))
    if ident.any() and not ident.all():  # an identity part is a global phase
        gen = SparsePauliOp(gen.paulis[~ident], gen.coeffs[~ident])
    if len(gen) == 1:
        r = abs(complex(gen.coeffs[0]))
        return ShiftRule((math.pi / (4 * r), -math.pi / (4 * r)), (r, -r))
    return _spectral_rule(name, gen, [circuit.find_bit(q).index for q in inst.qubits])


def _spectral_rule(name: str, gen: SparsePauliOp, qubits: list[int]) -> ShiftRule:
    """The rule read off the generator's spectrum on the gate's qubits: two eigenvalues
    ``{l, l + 2r}`` give the two-term rule, three equally spaced ``{l - d, l, l + d}`` the
    four-term rule of eq. 23 with angles scaled by ``d`` (controlled rotations: ``d = 1/2``)."""
    if len(qubits) > 10:
        raise ValueError(f"gate {name!r} spans {len(qubits)} qubits; no shift rule is derived "
                         "for a multi-term generator that wide")
    paulis = gen.paulis
    local = SparsePauliOp(PauliList.from_symplectic(paulis.z[:, qubits], paulis.x[:, qubits],
                                                    paulis.phase), gen.coeffs)
    eig = np.linalg.eigvalsh(local.to_matrix())
    levels = [eig[0]]
    for e in eig[1:]:
        if e - levels[-1] > 1e-9:
            levels.append(e)
    if len(levels) == 2:
        r = (levels[1] - levels[0]) / 2
        return ShiftRule((math.pi / (4 * r), -math.pi / (4 * r)), (r, -r))
    if len(levels) == 3 and abs((levels[2] - levels[1]) - (levels[1] - levels[0])) < 1e-9:
        d = levels[1] - levels[0]
        return ShiftRule(tuple(s / d for s, _ in _FOUR_TERM), tuple(c * d for _, c in _FOUR_TERM))
    raise ValueError(
        f"gate {name!r} has a generator with eigenvalues {np.round(levels, 6).tolist()}; shift "
        "rules are derived for two eigenvalues (two-term) or three equally spaced ones "
        "(four-term: RBS, FBS, controlled rotations)"
    )


@validates(
    circuit=Circuit(),
    parameters=[SequenceOf(Instance('qiskit.circuit:Parameter'), min_len=0), None],
)
def expand_occurrences(
    circuit: QuantumCircuit, parameters=None
) -> tuple[QuantumCircuit, list[tuple[Parameter, Parameter, float, object]]]:
    """Rewrite ``circuit`` with a fresh parameter for every gate occurrence of ``parameters``.

    Parameters
    ----------
    circuit : QuantumCircuit
    parameters : sequence of Parameter, optional
        Those to differentiate (default: all).

    Returns
    -------
    (QuantumCircuit, list)
        The expanded circuit and, per occurrence, ``(original parameter, fresh parameter,
        coefficient a, instruction)`` where the gate angle is ``a * p + b``.

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> from qiskit.circuit import Parameter
    >>> from qdensity.gradients import expand_occurrences
    >>> qc = QuantumCircuit(1); t = Parameter("t"); _ = qc.rx(t, 0); _ = qc.rz(2 * t, 0)
    >>> expanded, occurrences = expand_occurrences(qc)
    >>> expanded.num_parameters, [float(a) for _, _, a, _ in occurrences]
    (2, [1.0, 2.0])
    """
    wanted = set(circuit.parameters if parameters is None else parameters)
    occurrences: list[tuple] = []
    out = circuit.copy_empty_like()
    found = [parameter_of(inst) for inst in circuit.data]
    fresh = ParameterVector("_occ", sum(1 for po in found if po is not None and po[0] in wanted))
    # the instructions come from a valid circuit on the same bits: appended unchecked
    for inst, po in zip(circuit.data, found, strict=True):
        if po is None or po[0] not in wanted:
            out._append(inst)
            continue
        p, a = po
        q = fresh[len(occurrences)]
        new_params = [q if e is p else e.subs({p: q}) if hasattr(e, "parameters") and p in getattr(
            e, "parameters", ()) else e for e in inst.operation.params]
        op = inst.operation.copy()
        op.params = new_params
        out._append(inst.replace(operation=op))
        occurrences.append((p, q, a, inst))
    return out, occurrences


@validates(
    circuit=Circuit(),
    parameters=[SequenceOf(Instance('qiskit.circuit:Parameter'), min_len=0), None],
    rbs_rule=Options(('four_term', 'two_term')),
)
def shift_rules(circuit: QuantumCircuit, parameters=None, *, rbs_rule: str = "four_term"
                ) -> list[tuple[Parameter, float, ShiftRule]]:
    """The shift rule of every occurrence of ``parameters`` in ``circuit``, in circuit order.

    Returns
    -------
    list of (Parameter, float, ShiftRule)
        Per occurrence: the parameter, its coefficient ``a`` in the gate angle, the rule.

    Examples
    --------
    An RBS takes the four-term rule of eq. 23, a Pauli rotation the two-term rule:

    >>> from qiskit.circuit import Parameter
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.gradients import shift_rules
    >>> qc = round_robin(2); _ = qc.ry(Parameter("t"), 0)
    >>> [(p.name, rule.num_terms) for p, _, rule in shift_rules(qc)]
    [('θ[0]', 4), ('t', 2)]
    """
    _, occ = expand_occurrences(circuit, parameters)
    return [(p, a, _rule_for(inst, circuit, rbs_rule)) for p, _, a, inst in occ]


@validates(
    circuit=Circuit(min_qubits=1), observable=[Observable(), None],
    parameters=[SequenceOf(Instance('qiskit.circuit:Parameter'), min_len=0), None],
    rbs_rule=Options(('four_term', 'two_term')),
)
def shift_circuit_count(circuit: QuantumCircuit, observable: SparsePauliOp | None,
                        parameters=None, *, rbs_rule: str = "four_term") -> int:
    """Circuits per parameter row of :func:`parameter_shift_plan`, without its shifted rows.

    The sum of the rule terms over the occurrences of ``parameters``, times the qubit-wise
    commuting measurement groups of ``observable``'s non-identity terms (one for the
    probabilities, ``observable=None``): ``parameter_shift_plan(...).num_circuits / B``.

    Examples
    --------
    (4 + 2) rule terms, times 2 measurement groups (``ZZ`` and ``XI`` do not commute
    qubit-wise):

    >>> from qiskit.circuit import Parameter
    >>> from qiskit.quantum_info import SparsePauliOp
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.gradients import shift_circuit_count
    >>> qc = round_robin(2); _ = qc.ry(Parameter("t"), 0)
    >>> shift_circuit_count(qc, SparsePauliOp(["ZZ", "XI"])), shift_circuit_count(qc, None)
    (12, 6)
    """
    terms = sum(len(rule.shifts) for _, _, rule in shift_rules(circuit, parameters,
                                                               rbs_rule=rbs_rule))
    if observable is None:
        return terms
    groups = check_observable(observable, circuit.num_qubits).simplify().group_commuting(
        qubit_wise=True)
    return terms * sum(1 for g in groups if (g.paulis.x | g.paulis.z).any())


@validates(
    circuit=Circuit(min_qubits=1), observable=[Observable(), None],
    values=[Array(ndim=(1, 2), min_size=0, max_size=MAX_DENSE_ENTRIES), None],
    parameters=[SequenceOf(Instance('qiskit.circuit:Parameter'), min_len=0), None],
    shots=[Interval(int, 1, MAX_SHOTS), None], rbs_rule=Options(('four_term', 'two_term')),
    label=Instance(str), unary=Instance(bool),
)
def parameter_shift_plan(
    circuit: QuantumCircuit,
    observable: SparsePauliOp | None,
    values,
    *,
    parameters=None,
    shots: int | None = None,
    rbs_rule: str = "four_term",
    label: str = "shift",
    unary: bool = False,
) -> Plan:
    """Plan for the gradient of ``<O>`` (or of all outcome probabilities) by parameter shift.

    Parameters
    ----------
    circuit : QuantumCircuit
        Unmeasured circuit with ``P`` free parameters.
    observable : SparsePauliOp or None
        ``O``; None differentiates the computational-basis probabilities instead.
    values : array_like, shape (B, P) or (P,)
        Parameter rows in ``circuit.parameters`` order.
    parameters : sequence of Parameter, optional
        Which to differentiate (default: all); the output columns follow this order.
    shots : int, optional
        Shots per shifted circuit; exact when None.
    rbs_rule : {"four_term", "two_term"}
    unary : bool
        With ``observable=None``: differentiate only the ``n`` unary outcome probabilities
        ``p_j = P(e_j)``, read off the measured bits when sampled (any width, no dense
        ``2**n`` row).

    Returns
    -------
    Plan
        ``num_circuits = B * (sum of rule terms over occurrences) * (measurement groups)``.
        Post-processing returns an :class:`~qdensity.execution.plans.Estimate` whose ``value`` has
        shape
        (B, len(parameters)) for an observable, (B, 2**n, len(parameters)) for probabilities,
        (B, n, len(parameters)) with ``unary``.

    Examples
    --------
    A loader then ``RBS(t)``: ``<Z_0> = -cos 2t``, so the four-term rule gives ``2 sin 2t``
    exactly:

    >>> import numpy as np
    >>> from qiskit import QuantumCircuit
    >>> from qiskit.quantum_info import SparsePauliOp
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.execution.engines import ExactEngine
    >>> from qdensity.gradients import parameter_shift_plan
    >>> qc = QuantumCircuit(2); _ = qc.x(0); qc = qc.compose(round_robin(2))
    >>> plan = parameter_shift_plan(qc, SparsePauliOp("IZ"), [[0.3], [1.1]])
    >>> est = plan.run(ExactEngine())
    >>> plan.num_circuits, bool(np.allclose(est.value[:, 0], 2 * np.sin([0.6, 2.2])))
    (8, True)
    """
    if unary and observable is not None:
        raise ValueError("unary=True differentiates the unary outcome probabilities; give "
                         "observable=None with it")
    vals = as_parameter_rows(values, circuit.num_parameters)
    params = list(circuit.parameters) if parameters is None else list(parameters)
    known = set(circuit.parameters)  # once: circuit.parameters sorts on every access
    unknown = [p for p in params if p not in known]
    if unknown:
        raise ValueError(f"parameters {[p.name for p in unknown]} are not in the circuit")
    col = {p: i for i, p in enumerate(params)}
    expanded, occ = expand_occurrences(circuit, params)
    rules = [_rule_for(inst, circuit, rbs_rule) for _, _, _, inst in occ]
    # base values of the expanded circuit: originals copied into each occurrence's fresh param
    src = {p: i for i, p in enumerate(circuit.parameters)}
    fresh_of = {q: p for p, q, _, _ in occ}
    exp_params = list(expanded.parameters)
    base = np.stack(
        [vals[:, src[fresh_of.get(p, p)]] for p in exp_params], axis=1
    ) if exp_params else np.zeros((vals.shape[0], 0))
    exp_index = {p: i for i, p in enumerate(exp_params)}
    weights = []  # per block of B rows: (occurrence index, coefficient)
    cols, moves = [], []  # per block: the occurrence's column and its parameter's shift
    for o, ((_p, q, a, _), rule) in enumerate(zip(occ, rules, strict=True)):
        if a == 0:
            raise ValueError(f"parameter {_p.name} enters a gate with coefficient 0")
        for s, c in zip(rule.shifts, rule.coeffs, strict=True):
            cols.append(exp_index[q])
            moves.append(s / a)  # the gate angle a*p + b moves by s
            weights.append((o, c))
    B = vals.shape[0]
    # (blocks, B, P): one copy of base each (a broadcast copy: np.tile is ~20x slower here)
    blocks = np.broadcast_to(base, (len(weights), *base.shape)).copy()
    if weights:
        blocks[np.arange(len(weights)), :, np.asarray(cols)] += np.asarray(moves)[:, None]
    rows = blocks.reshape(len(weights) * B, len(exp_params))
    if observable is not None:
        inner = expectation_plan(expanded, observable, rows, shots=shots, label=label)
    else:
        inner = probabilities_plan(expanded, rows, shots=shots, label=label)

    post = partial(_shift_post, inner, observable is not None, B, len(params), weights, occ, col,
                   unary)

    plan = Plan(inner.jobs, post, f"parameter shift ({rbs_rule}) of {circuit.name}: "
                f"{len(occ)} occurrences, {rows.shape[0]} shifted rows")
    plan.meta["occurrences"] = len(occ)
    return plan


def _shift_post(inner, has_observable, B, num_params, weights, occ, col, unary, results):
    """Combine shifted evaluations into the gradient (module level, so plans pickle)."""
    raw = inner.postprocess(results)
    if has_observable:
        f, se = raw.value, raw.standard_error
        out = np.zeros((B, num_params))
        var = np.zeros((B, num_params))
    elif unary:  # the unary frequencies, from the measured bits when sampled
        f, _ = unary_frequencies(raw)
        se = (binomial_standard_error(np.clip(f, 0.0, 1.0), raw.sample_size)
              if raw.shots is not None else np.zeros_like(f))
        out = np.zeros((B, f.shape[1], num_params))
        var = np.zeros_like(out)
    else:
        f = raw.probabilities
        se = (binomial_standard_error(f, raw.shots) if raw.shots is not None
              else np.zeros_like(f))
        out = np.zeros((B, f.shape[1], num_params))
        var = np.zeros_like(out)
    for blk, (o, c) in enumerate(weights):
        p, _q, a, _ = occ[o]
        seg = slice(blk * B, (blk + 1) * B)
        w = a * c
        if has_observable:
            out[:, col[p]] += w * f[seg]
            var[:, col[p]] += (w * se[seg]) ** 2
        else:
            out[:, :, col[p]] += w * f[seg]
            var[:, :, col[p]] += (w * se[seg]) ** 2
    return Estimate(out, np.sqrt(var))
