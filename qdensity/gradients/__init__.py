"""Gradients: parameter shift (Supp. E), commuting-generator circuits (Prop. 1, Cor. 2,
Supp. F.3) and density-QNN gradients (Cor. 1, Prop. 1, chain rule through mixtures)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from qdensity._lazy import lazy_exports

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

#: public name -> the module that defines it, imported on first use (PEP 562)
_EXPORTS: dict[str, str] = {
    "commuting_blocks": "qdensity.analysis.blocks",
    "CommutingBlockGradient": "qdensity.gradients.blocks",
    "commuting_block_gradient": "qdensity.gradients.blocks",
    "CommutingGradient": "qdensity.gradients.commuting",
    "commuting_gradient": "qdensity.gradients.commuting",
    "commuting_gradient_count": "qdensity.gradients.commuting",
    "DensityGradient": "qdensity.gradients.density",
    "chain_rule": "qdensity.gradients.density",
    "density_gradient_plan": "qdensity.gradients.density",
    "gradient_circuit_count": "qdensity.gradients.density",
    "subunitary_jacobian_plan": "qdensity.gradients.density",
    "expand_occurrences": "qdensity.gradients.shift",
    "parameter_shift_plan": "qdensity.gradients.shift",
    "shift_circuit_count": "qdensity.gradients.shift",
    "shift_rules": "qdensity.gradients.shift",
}

if TYPE_CHECKING:  # static analysers and IDEs see the eager imports
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


if not TYPE_CHECKING:  # type checkers see the imports above, not a catch-all lookup
    __getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, __all__)
