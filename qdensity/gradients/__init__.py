"""Gradients: parameter shift (Supp. E), commuting-generator circuits (Prop. 1, Cor. 2,
Supp. F.3) and density-QNN gradients (Cor. 1, Prop. 1, chain rule through mixtures)."""

from qdensity.analysis.blocks import commuting_blocks
from qdensity.gradients.blocks import CommutingBlockGradient, commuting_block_gradient
from qdensity.gradients.commuting import (
    CommutingGradient,
    commuting_gradient,
    commuting_gradient_count,
)
from qdensity.gradients.density import (
    DensityGradient,
    chain_rule,
    density_gradient_plan,
    gradient_circuit_count,
    subunitary_jacobian_plan,
)
from qdensity.gradients.shift import (
    expand_occurrences,
    parameter_shift_plan,
    shift_circuit_count,
    shift_rules,
)

__all__ = [
    "parameter_shift_plan",
    "shift_rules",
    "shift_circuit_count",
    "expand_occurrences",
    "commuting_gradient",
    "commuting_gradient_count",
    "commuting_block_gradient",
    "commuting_blocks",
    "CommutingGradient",
    "CommutingBlockGradient",
    "density_gradient_plan",
    "gradient_circuit_count",
    "subunitary_jacobian_plan",
    "chain_rule",
    "DensityGradient",
]
