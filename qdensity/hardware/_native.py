"""The ``rbs_native`` target's device: native basis, noise, Target, RBS rewriting, simulator.

A trapped-ion-like all-to-all device whose native two-qubit gate is the beam splitter
``xx_plus_yy``: ``RBSGate(theta)`` *equals* ``XXPlusYYGate(2 theta, pi/2)``, so a circuit of
``m`` RBS gates (paper eq. 8) compiles to exactly ``m`` native two-qubit gates. This module
holds the pieces :func:`qdensity.hardware.targets.get_target` and
:class:`qdensity.hardware.targets.HardwareTarget`
assemble for it: the basis :data:`RBS_NATIVE_BASIS` and noise :data:`RBS_NATIVE_NOISE` (both
re-exported by :mod:`qdensity.hardware.targets`), the transpiler ``Target``, the exact rewriting of
RBS
gates as native gates, and the Aer simulator that lowers native gates at run time:

Aer has no ``xx_plus_yy`` instruction. The ``rbs_native`` simulator therefore lowers each native
gate at run time to ``rz(beta) . ryy(theta/2) . rxx(theta/2) . rz(-beta)`` (an exact identity)
and tags the ``rxx`` with the label ``"xx_plus_yy"``; Aer looks noise up by label, so the native
gate's error is applied exactly once, right after the interaction. The error (depolarizing, then
thermal relaxation) commutes with the trailing ``rz``, so this equals the error after the whole
native gate.
"""

from __future__ import annotations

import math

from qiskit.circuit import Delay, Gate, Measure, Parameter, QuantumCircuit, Reset
from qiskit.circuit.library import (
    RXXGate,
    RYYGate,
    RZGate,
    SXGate,
    XGate,
    XXPlusYYGate,
    get_standard_gate_name_mapping,
)
from qiskit.transpiler import InstructionProperties, Target

from qdensity.circuits.gates import RBSGate
from qdensity.hardware._served_noise import ServedNoiseSimulator

__all__ = ["RBS_NATIVE_BASIS", "RBS_NATIVE_NOISE"]

#: Native gates of the ``rbs_native`` target.
RBS_NATIVE_BASIS = ("xx_plus_yy", "rxx", "rz", "sx", "x")

#: Noise of the ``rbs_native`` target (times in seconds), trapped-ion-like: long T1, T2 of a
#: second, slow gates, two-qubit depolarizing ``5e-3``.
RBS_NATIVE_NOISE = {
    "depolarizing_1q": 5e-4,
    "depolarizing_2q": 5e-3,
    "t1": 100.0,
    "t2": 1.0,
    "gate_time_1q": 1e-5,
    "gate_time_2q": 2e-4,
    "readout_error": 4e-3,
}

_RBS_NATIVE_MEASURE_TIME = 1e-4
_NATIVE_XY_LABEL = "xx_plus_yy"


def _rbs_native_target(n: int) -> Target:
    """The ``rbs_native`` Target: durations and average gate errors from RBS_NATIVE_NOISE."""
    p = RBS_NATIVE_NOISE
    # average gate infidelity of a depolarizing channel lambda on dimension d: lambda (d-1)/d
    err_1q = p["depolarizing_1q"] / 2
    err_2q = 3 * p["depolarizing_2q"] / 4
    target = Target(description="rbs_native: trapped-ion-like, native RBS (xx_plus_yy)",
                    num_qubits=n)
    pairs = [(i, j) for i in range(n) for j in range(n) if i != j]

    def props_2q():
        return {q: InstructionProperties(duration=p["gate_time_2q"], error=err_2q) for q in pairs}

    def props_1q(duration, error):
        return {(q,): InstructionProperties(duration=duration, error=error) for q in range(n)}

    target.add_instruction(XXPlusYYGate(Parameter("theta"), Parameter("beta")), props_2q())
    target.add_instruction(RXXGate(Parameter("theta")), props_2q())
    target.add_instruction(RZGate(Parameter("phi")), props_1q(0.0, 0.0))
    target.add_instruction(SXGate(), props_1q(p["gate_time_1q"], err_1q))
    target.add_instruction(XGate(), props_1q(p["gate_time_1q"], err_1q))
    target.add_instruction(Measure(), props_1q(_RBS_NATIVE_MEASURE_TIME, p["readout_error"]))
    target.add_instruction(Reset(), {(q,): None for q in range(n)})
    target.add_instruction(Delay(Parameter("t")), {(q,): None for q in range(n)})
    return target


def _rbs_to_native(circuit: QuantumCircuit) -> QuantumCircuit:
    """Write every RBS(theta) as XXPlusYY(2 theta, pi/2) (exact), inlining gates that hold RBS."""
    if not any(_holds_rbs(inst.operation) for inst in circuit.data):
        return circuit
    out = circuit.copy_empty_like()
    for inst in circuit.data:
        op = inst.operation
        if isinstance(op, RBSGate):
            out.append(XXPlusYYGate(2 * op.params[0], math.pi / 2), inst.qubits, inst.clbits)
        elif _holds_rbs(op):
            out.compose(_rbs_to_native(op.definition), qubits=inst.qubits, clbits=inst.clbits,
                        inplace=True)
        else:
            out.append(inst)
    return out


def _holds_rbs(op) -> bool:
    """RBS itself, or a non-standard gate whose definition (recursively) contains one."""
    if isinstance(op, RBSGate):
        return True
    if not isinstance(op, Gate) or op.name in get_standard_gate_name_mapping():
        return False
    definition = op.definition
    return definition is not None and any(_holds_rbs(i.operation) for i in definition.data)


def _lower_native_xy(circuit: QuantumCircuit) -> QuantumCircuit:
    """XXPlusYY(theta, beta) -> rz(beta) ryy(theta/2) rxx(theta/2)[label] rz(-beta), exactly."""
    if not any(isinstance(inst.operation, XXPlusYYGate) for inst in circuit.data):
        return circuit
    out = circuit.copy_empty_like()
    for inst in circuit.data:
        if isinstance(inst.operation, XXPlusYYGate):
            theta, beta = inst.operation.params
            q0, q1 = inst.qubits
            out.rz(beta, q0)
            out.append(RYYGate(theta / 2), [q0, q1])
            out.append(RXXGate(theta / 2, label=_NATIVE_XY_LABEL), [q0, q1])
            out.rz(-beta, q0)
        else:
            out.append(inst)
    return out


class _NativeXYSimulator(ServedNoiseSimulator):
    """AerSimulator that lowers native ``xx_plus_yy`` gates before running (rbs_native)."""

    def run(self, circuits, parameter_binds=None, **run_options):
        if isinstance(circuits, QuantumCircuit):
            lowered = _lower_native_xy(circuits)
        else:
            lowered = [_lower_native_xy(c) for c in circuits]
        return super().run(lowered, parameter_binds=parameter_binds, **run_options)
