"""The statevector engine: exact expectation values and adjoint gradients on a ``2**n`` state.

:class:`AdjointEngine` compiles a circuit to (controlled) Pauli rotations and fixed gates
(:mod:`._program`) and runs it with numba's compiled kernels (:mod:`._kernels`,
:mod:`._kernels_planar`, the moving qubit layout of :mod:`._layout`), or with numpy gathers
where numba is switched off (``QDENSITY_NUMBA=0``).
"""

from qdensity.execution.statevector.adjoint import AdjointEngine

__all__ = ["AdjointEngine"]
