"""The ansatz-family registry: one entry per named sub-unitary family.

An :class:`AnsatzFamily` states once what every layer needs to know about a family: its
builder (number of qubits -> ``QuantumCircuit``), its parameter count as a function of ``n``
(declared, or read off the built circuit), the gradient method it is differentiated with
(paper Table 1), the model readouts it supports, the sizes it accepts, whether the estimators'
``ansatz=`` may name it, and its name on the command line. The estimators
(``QNNClassifier(ansatz=...)``), their saved files, ``qdensity build`` / ``qdensity transpile``
and ``qdensity sweep`` all read :data:`FAMILIES`; registering a family here makes it usable
from all of them.

Examples
--------
>>> from qdensity.circuits.ansatze.registry import FAMILIES
>>> fam = FAMILIES["pyramid"]
>>> fam.parameter_count(6), fam.builder(6).num_parameters
(15, 15)
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

from qiskit import QuantumCircuit

from qdensity.circuits.ansatze.equivariant import equivariant_commuting, equivariant_noncommuting
from qdensity.circuits.ansatze.hamming import butterfly, pyramid, round_robin, x_circuit
from qdensity.circuits.ansatze.hardware_efficient import hardware_efficient
from qdensity.circuits.ansatze.qcnn import qcnn
from qdensity.circuits.ansatze.reuploading import reuploading
from qdensity.validation import CallableC, Instance, Interval, SequenceOf, validates

__all__ = ["AnsatzFamily", "FAMILIES", "register_family", "estimator_ansatze"]


@validates(
    name=Instance(str), builder=CallableC("f(num_qubits) -> QuantumCircuit"),
    num_parameters=[CallableC("f(num_qubits) -> int"), None], gradient=Instance(str),
    readouts=[SequenceOf(Instance(str)), None], min_qubits=Interval(int, 1),
    power_of_two=Instance(bool), estimator=Instance(bool), cli_name=[Instance(str), None],
)
@dataclass(frozen=True)
class AnsatzFamily:
    """One named ansatz family.

    Attributes
    ----------
    name : str
        The family's name (the estimators' ``ansatz=`` value, and the key in saved files).
    builder : callable
        ``builder(num_qubits) -> QuantumCircuit`` with a ``ParameterVector``.
    num_parameters : callable or None
        ``num_parameters(num_qubits) -> int``, known before building (saved files refuse a
        spec too large to build from it); None reads it off the built circuit.
    gradient : str
        The ``method=`` of :func:`~qdensity.gradients.density.density_gradient_plan` the
        family is differentiated with (``"shift"`` or ``"commuting"``; paper Table 1).
    readouts : sequence of str or None
        The ``DensityQNN`` readouts its circuits support; None: every one of
        :data:`qdensity.models.density.READOUTS` (a weight-preserving family on unary inputs).
    min_qubits : int
        Smallest size it builds.
    power_of_two : bool
        Whether the size must be a power of two (the butterfly).
    estimator : bool
        Whether the estimators' ``ansatz=`` may name it (unary-encoded, weight-preserving).
    cli_name : str or None
        Its name in ``qdensity build`` / ``transpile`` when not ``name``.

    Examples
    --------
    >>> from qdensity.circuits.ansatze import round_robin
    >>> fam = AnsatzFamily("my_rr", round_robin, num_parameters=lambda n: n * (n - 1) // 2)
    >>> fam.parameter_count(4), fam.builder(4).num_parameters
    (6, 6)
    """

    name: str
    builder: Callable[[int], QuantumCircuit]
    num_parameters: Callable[[int], int] | None = None
    gradient: str = "shift"
    readouts: tuple[str, ...] | None = ("observable",)
    min_qubits: int = 2
    power_of_two: bool = False
    estimator: bool = False
    cli_name: str | None = None

    @property
    def command_name(self) -> str:
        """The name ``qdensity build`` and ``qdensity transpile`` know it by."""
        return self.cli_name or self.name

    def accepts(self, num_qubits: int) -> bool:
        """Whether the family builds on ``num_qubits`` qubits."""
        n = int(num_qubits)
        return n >= self.min_qubits and not (self.power_of_two and n & (n - 1))

    def parameter_count(self, num_qubits: int) -> int:
        """Angles of the family on ``num_qubits`` qubits: the declared count, else the built
        circuit's ``num_parameters``."""
        if self.num_parameters is not None:
            return int(self.num_parameters(num_qubits))
        return self.builder(num_qubits).num_parameters

    def __reduce_ex__(self, protocol):
        # a registered entry (its functions may be closures or lambdas) pickles and copies as
        # its name: it loads as the entry registered under that name
        if FAMILIES.get(self.name) is self:
            return (_registered, (self.name,))
        return super().__reduce_ex__(protocol)


#: The registry: family name -> :class:`AnsatzFamily`, in the order listings show them.
FAMILIES: dict[str, AnsatzFamily] = {}


def _registered(name: str):
    """The registered entry ``name`` (what a registered entry pickles to)."""
    return FAMILIES[name]


@validates(family=Instance(AnsatzFamily))
def register_family(family: AnsatzFamily) -> AnsatzFamily:
    """Add ``family`` to :data:`FAMILIES` and return it.

    Raises
    ------
    ValueError
        If its name (or its command-line name) is taken already, or an estimator family
        declares no parameter count.

    Examples
    --------
    >>> from qdensity.circuits.ansatze import round_robin
    >>> fam = register_family(AnsatzFamily("my_rr", round_robin))
    >>> "my_rr" in FAMILIES
    True
    >>> register_family(AnsatzFamily("my_rr", round_robin))
    Traceback (most recent call last):
        ...
    ValueError: family: an ansatz family named 'my_rr' ('my_rr') is registered already
    >>> del FAMILIES["my_rr"]  # leave the registry as it was
    """
    if family.estimator and family.num_parameters is None:
        raise ValueError(f"family: {family.name!r} is an estimator ansatz and must declare "
                         "num_parameters (saved files check it before building)")
    taken = {f.command_name for f in FAMILIES.values()} | set(FAMILIES)
    if family.name in taken or family.command_name in taken:
        raise ValueError(f"family: an ansatz family named {family.name!r} "
                         f"({family.command_name!r}) is registered already")
    FAMILIES[family.name] = family
    return family


def estimator_ansatze() -> tuple[str, ...]:
    """Names the estimators' ``ansatz=`` accepts, read off :data:`FAMILIES` at each call.

    Examples
    --------
    >>> estimator_ansatze()
    ('pyramid', 'x', 'butterfly', 'round_robin')
    """
    return tuple(name for name, fam in FAMILIES.items() if fam.estimator)


def _pairs(n: int) -> int:
    return n * (n - 1) // 2


def _x_count(n: int) -> int:
    return 2 * n - 3 + n % 2


def _butterfly_count(n: int) -> int:
    return (n // 2) * max(n.bit_length() - 1, 0)


register_family(AnsatzFamily("pyramid", pyramid, _pairs, readouts=None,
                             estimator=True))
register_family(AnsatzFamily("x", x_circuit, _x_count, readouts=None, estimator=True,
                             cli_name="x_circuit"))
register_family(AnsatzFamily("butterfly", butterfly, _butterfly_count, readouts=None,
                             power_of_two=True, estimator=True))
register_family(AnsatzFamily("round_robin", round_robin, _pairs, readouts=None,
                             estimator=True))
register_family(AnsatzFamily("hardware_efficient", partial(hardware_efficient, reps=2)))
register_family(AnsatzFamily("equivariant_xx", partial(equivariant_commuting, pauli="X"),
                             gradient="commuting", min_qubits=3))
register_family(AnsatzFamily("equivariant_yy", partial(equivariant_commuting, pauli="Y"),
                             gradient="commuting", min_qubits=3))
register_family(AnsatzFamily("equivariant_noncommuting",
                             partial(equivariant_noncommuting, layers=2)))
register_family(AnsatzFamily("qcnn", qcnn))
register_family(AnsatzFamily("reuploading", reuploading, min_qubits=1))
