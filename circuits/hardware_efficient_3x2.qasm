OPENQASM 2.0;
// hardware_efficient_3x2: Hardware-efficient ansatz (Fig. 3): 2 layers of RY rotations and CNOT ladders.
include "qelib1.inc";
qreg q[3];
ry(-2.7529478240662097) q[0];
ry(-0.6410165174806952) q[1];
cx q[0],q[1];
ry(-0.07694502010026616) q[0];
ry(-2.854770097327562) q[2];
cx q[1],q[2];
ry(-1.5494278631146439) q[1];
ry(-1.7298856014152848) q[2];
cx q[2],q[1];
cx q[1],q[0];
