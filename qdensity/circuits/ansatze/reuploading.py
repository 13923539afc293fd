"""Single-qubit data re-uploading model and the Chebyshev regression task (paper Fig. 6).

Methods "Data reuploading" (eq. 10-11) and Supp. G.3: layer ``l`` applies the data encoding
``V(x)`` and then the trainable ``U_l = R_z(θ^1_l) R_y(θ^2_l) R_z(θ^3_l)``, so the state is
``U_L V(x) ... U_1 V(x) |0>``. The encoding is the Hamiltonian encoding
``V(x) = R_x(x) = exp(-i x X / 2)`` by default (``R_y`` on request); each upload adds the
frequencies ``±1`` to the model's Fourier spectrum, so ``L`` layers give a partial Fourier series
of degree ``L`` in ``x``.
"""

from __future__ import annotations

from qiskit.circuit import ParameterVector, QuantumCircuit

from qdensity.datasets.chebyshev import chebyshev_dataset
from qdensity.validation import Instance, Layers, Options, validates

__all__ = ["reuploading", "chebyshev_dataset", "ENCODINGS"]

#: Encoding gates a re-uploading layer may use.
ENCODINGS = ("rx", "ry")


@validates(
    layers=Layers(), encoding=Options(ENCODINGS), parameter_prefix=Instance(str),
    data_prefix=Instance(str), name=[Instance(str), None],
)
def reuploading(
    layers: int,
    *,
    encoding: str = "rx",
    parameter_prefix: str = "θ",
    data_prefix: str = "x",
    name: str | None = None,
) -> QuantumCircuit:
    """Single-qubit data re-uploading circuit with ``layers`` uploads (Methods eq. 10-11).

    Layer ``l = 0 .. L - 1`` appends ``R_enc(x)`` and then ``rz(θ[3l + 2])``, ``ry(θ[3l + 1])``,
    ``rz(θ[3l])`` -- in matrix form ``U_l = R_z(θ[3l]) R_y(θ[3l + 1]) R_z(θ[3l + 2])``, the
    paper's ``R_z(θ^1_l) R_y(θ^2_l) R_z(θ^3_l)``. The whole circuit is
    ``U_{L-1} R_enc(x) ... U_0 R_enc(x)``.

    Parameter count: ``3 L`` trainable parameters plus the single data parameter ``x[0]``.
    ``circuit.parameters`` is sorted by name, so with the default prefixes it reads
    ``[x[0], θ[0], ..., θ[3L - 1]]``; split data from trainable parameters by vector name.

    Parameters
    ----------
    layers : int
        Number of uploads ``L >= 1``.
    encoding : {"rx", "ry"}
        Encoding gate ``R_x(x)`` (default) or ``R_y(x)``.
    parameter_prefix : str
        Name of the trainable ``ParameterVector`` (length ``3 L``).
    data_prefix : str
        Name of the data ``ParameterVector`` (length 1).
    name : str, optional
        Circuit name; defaults to ``"reuploading_{L}"``.

    Returns
    -------
    QuantumCircuit
        One qubit; ``L`` encoding gates and ``3 L`` trainable rotations.

    Raises
    ------
    ValueError
        For ``layers < 1`` or an unknown ``encoding``.

    Examples
    --------
    >>> qc = reuploading(2)
    >>> qc.num_parameters, [inst.operation.name for inst in qc.data][:4]
    (7, ['rx', 'rz', 'ry', 'rz'])
    """
    num_layers = int(layers)
    if parameter_prefix == data_prefix:
        raise ValueError(
            f"parameter_prefix and data_prefix must differ, both are {parameter_prefix!r}"
        )
    theta = ParameterVector(parameter_prefix, 3 * num_layers)
    x = ParameterVector(data_prefix, 1)
    qc = QuantumCircuit(1, name=name or f"reuploading_{num_layers}")
    for layer in range(num_layers):
        getattr(qc, encoding)(x[0], 0)
        qc.rz(theta[3 * layer + 2], 0)
        qc.ry(theta[3 * layer + 1], 0)
        qc.rz(theta[3 * layer], 0)
    return qc
