"""Structure read off circuits: moments (parallel layers), Pauli generators, Hamming-weight
preservation (:mod:`~qdensity.analysis.structure`), the Pauli / Clifford algebra behind the
commuting-generator gradients (:mod:`~qdensity.analysis.pauli`; paper Prop. 1, Supp. F.3), and
the commuting blocks of a circuit (:mod:`~qdensity.analysis.blocks`; paper eq. 9, Cor. 2), and
the gate registry that all of them read (:mod:`~qdensity.analysis.gate_registry`: matrix,
generator, shift rule, Hamming-weight behaviour per gate name)."""

from qdensity.analysis.blocks import commuting_blocks
from qdensity.analysis.gate_registry import (
    FBS,
    GATES,
    GIVENS_GATES,
    RBS,
    GateKind,
    gate_kind,
    register_gate,
)
from qdensity.analysis.pauli import (
    as_pauli_list,
    commutation_matrix,
    conjugate_two_qubit,
    diagonalising_clifford,
    first_noncommuting_pair,
    paulis_commute_pairwise,
    z_string_values,
)
from qdensity.analysis.structure import (
    HW_PRESERVING_GATES,
    depth_of_gates,
    instruction_generator,
    is_hamming_weight_preserving,
    moment_indices,
    moments,
    parameter_of,
)

__all__ = [
    "moments",
    "moment_indices",
    "depth_of_gates",
    "instruction_generator",
    "parameter_of",
    "is_hamming_weight_preserving",
    "HW_PRESERVING_GATES",
    "as_pauli_list",
    "commutation_matrix",
    "paulis_commute_pairwise",
    "first_noncommuting_pair",
    "diagonalising_clifford",
    "z_string_values",
    "conjugate_two_qubit",
    "commuting_blocks",
    "GateKind",
    "GATES",
    "gate_kind",
    "register_gate",
    "RBS",
    "FBS",
    "GIVENS_GATES",
]
