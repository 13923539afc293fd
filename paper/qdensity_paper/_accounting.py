"""Circuits per data point as a device would pay them, broken down (issue "The paper at its own
protocol", item 3).

One training step of a density QNN on hardware runs, per data point:

* **forward**: one circuit per sub-unitary (``f_k``, needed for ``d f / d alpha`` and the loss);
* **parameter gradients**: each sub-unitary's gradient circuits (commuting-generator circuits,
  or the four-term parameter shift per RBS angle; :func:`~qdensity.gradients.
  gradient_circuit_count`);
* **input gradients**: where a classical layer sits in front of the loader (the hybrid models of
  Fig. 11a), training it needs ``d f / d x``, the gradient with respect to the loader's ``n - 1``
  angles, for every sub-unitary: the four-term rule on each loader RBS of the circuit
  ``loader + U_k`` (:func:`~qdensity.gradients.shift_circuit_count`);
* **calibration**: mitigation calibration circuits, per run rather than per data point.

:func:`circuit_breakdown` returns these counts; :func:`breakdown_metrics` flattens them into an
experiment's metrics (``{prefix}/circuits/...``).
"""

from __future__ import annotations

import numpy as np

from qdensity.circuits.loaders import unary_loader_template
from qdensity.gradients.density import subunitary_jacobian_plan
from qdensity.gradients.shift import shift_circuit_count

__all__ = ["circuit_breakdown", "breakdown_metrics", "input_gradient_circuits"]


def input_gradient_circuits(model, k: int, layout: str = "parallel") -> int:
    """Circuits per data point for the gradient of sub-unitary ``k``'s unary probabilities with
    respect to the loader's angles (four-term shift on each loader RBS, whose qubits later gates
    touch)."""
    n = model.num_qubits
    loader = unary_loader_template(n, layout=layout, parameter_prefix="load")
    circuit = loader.compose(model.sub_unitaries[k])
    obs = model.observable if model.readout == "observable" else None
    return shift_circuit_count(circuit, obs, list(loader.parameters))


def circuit_breakdown(model, X_row, *, method: str = "auto", input_gradients: bool = False,
                      calibration_circuits: int = 0, loader_layout: str = "parallel") -> dict:
    """Circuits one sampled training step runs per data point, by kind.

    Parameters
    ----------
    model : DensityQNN
        Unary-encoded (a loader in front) when ``input_gradients``.
    X_row : array_like, shape (1, d)
        One input (the counts do not depend on its values).
    method : {"auto", "shift", "commuting"}
        Gradient method of the sub-unitaries' parameters.
    input_gradients : bool
        A classical layer sits in front of the loader and trains.
    calibration_circuits : int
        Mitigation calibration circuits of the run (not per data point).
    loader_layout : str
        Layout of the loader whose angles carry the input.

    Returns
    -------
    dict
        ``forward`` (K), ``parameter_gradients`` (list of K counts), ``input_gradients`` (list
        of K counts, zeros without a classical layer in front), ``per_point`` (their sum) and
        ``calibration`` (per run).
    """
    K = model.num_subunitaries
    X_row = np.atleast_2d(np.asarray(X_row, dtype=float))[:1]
    params = [int(subunitary_jacobian_plan(model, k, X_row, method=method).num_circuits)
              for k in range(K)]
    inputs = [input_gradient_circuits(model, k, loader_layout) if input_gradients else 0
              for k in range(K)]
    if isinstance(calibration_circuits, bool) or int(calibration_circuits) < 0:
        raise ValueError(f"calibration_circuits must be a non-negative int, got "
                         f"{calibration_circuits!r}")
    return {"forward": K, "parameter_gradients": params, "input_gradients": inputs,
            "per_point": K + sum(params) + sum(inputs), "calibration": int(calibration_circuits)}


def breakdown_metrics(prefix: str, breakdown: dict) -> dict:
    """``breakdown`` as flat metrics: ``{prefix}/circuits/forward``, ``.../parameter_gradients``
    (sum) and ``.../parameter_gradients_k{k}``, ``.../input_gradients`` (sum),
    ``.../calibration`` and ``{prefix}/circuits_per_row`` (the per-point total)."""
    out = {f"{prefix}/circuits/forward": breakdown["forward"],
           f"{prefix}/circuits/parameter_gradients": sum(breakdown["parameter_gradients"]),
           f"{prefix}/circuits/input_gradients": sum(breakdown["input_gradients"]),
           f"{prefix}/circuits/calibration": breakdown["calibration"],
           f"{prefix}/circuits_per_row": breakdown["per_point"]}
    for k, c in enumerate(breakdown["parameter_gradients"]):
        out[f"{prefix}/circuits/parameter_gradients_k{k}"] = c
    return out
