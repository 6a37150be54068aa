"""Writes the .mat test files of host/ssm/tests/mat_files.rs, without MATLAB.

Run from this folder with numpy, scipy and h5py installed (e.g. in a venv):

    python make_mat.py

Outputs (all small, committed next to this script):

* duffing_{1,2,3}.csv: a damped Duffing oscillator x'' + 2 zeta w x' + w^2 x + k x^3 = 0
  (w = 2 pi rad/s, zeta = 0.02, k = 20), integrated with scipy's DOP853 at rtol 1e-12 and
  sampled every 0.02 s for 6 s from three initial amplitudes; columns t, x, v (= x'), and
  x2 (= x + 0.5 x^2, a nonlinear observable). Values printed with repr(), so the CSV text
  reads back bit for bit.
* duffing.mat: SSMLearn's layout, written by scipy.io.savemat with compression (v5
  miCOMPRESSED): xData a 3 x 2 cell array, row i = {t (1 x N), X (3 x N: rows x, v, x2)},
  built from the CSV values read back from the files above, so reader == CSV exactly.
* duffing_plain.mat: the same without compression, t stored as a column vector (N x 1),
  after a char variable `note`.
* mismatch.mat: two trajectories with 3 and 2 observables.
* transposed.mat: X stored N x 3 (one column per observable).
* notcell.mat: xData a plain double matrix.
* v73.mat: an HDF5 file with MATLAB's 512-byte user block header ("MATLAB 7.3 MAT-file"),
  as MATLAB's save(..., '-v7.3') writes, made with h5py.
"""

import numpy as np
import scipy.io
from scipy.integrate import solve_ivp

W, ZETA, K = 2 * np.pi, 0.02, 20.0
DT, T_END = 0.02, 6.0


def rhs(_t, s):
    x, v = s
    return [v, -2 * ZETA * W * v - W * W * x - K * x**3]


def write_csv(path, t, cols):
    with open(path, "w") as f:
        f.write("t,x,v,x2\n")
        for row in zip(t, *cols):
            f.write(",".join(repr(float(v)) for v in row) + "\n")


def read_csv(path):
    a = np.loadtxt(path, delimiter=",", skiprows=1)
    return a[:, 0], a[:, 1:].T.copy()


def cells(trajs):
    c = np.empty((len(trajs), 2), dtype=object)
    for i, (t, x) in enumerate(trajs):
        c[i, 0] = t.reshape(1, -1)
        c[i, 1] = x
    return c


def main():
    t = np.round(np.arange(0, T_END + DT / 2, DT), 12)
    trajs = []
    for i, x0 in enumerate([0.6, 0.45, 0.3], start=1):
        sol = solve_ivp(rhs, (0, t[-1]), [x0, 0.0], t_eval=t, method="DOP853", rtol=1e-12, atol=1e-14)
        x, v = sol.y
        write_csv(f"duffing_{i}.csv", t, [x, v, x + 0.5 * x * x])
        trajs.append(read_csv(f"duffing_{i}.csv"))
    scipy.io.savemat("duffing.mat", {"xData": cells(trajs)}, do_compression=True)
    # t as a column vector in the uncompressed file, next to a char variable the reader
    # does not need (and does not parse).
    plain = cells(trajs)
    for i in range(plain.shape[0]):
        plain[i, 0] = plain[i, 0].reshape(-1, 1)
    scipy.io.savemat("duffing_plain.mat", {"note": "uncompressed", "xData": plain}, do_compression=False)
    mixed = cells(trajs[:2])
    mixed[1, 1] = mixed[1, 1][:2]
    scipy.io.savemat("mismatch.mat", {"xData": mixed}, do_compression=True)
    tr = cells(trajs[:1])
    tr[0, 1] = tr[0, 1].T.copy()
    scipy.io.savemat("transposed.mat", {"xData": tr}, do_compression=True)
    scipy.io.savemat("notcell.mat", {"xData": np.vstack([trajs[0][0], trajs[0][1]])}, do_compression=True)

    import h5py

    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Thu Jan  1 00:00:00 2026 HDF5 schema 1.00 ."
    with h5py.File("v73.mat", "w", userblock_size=512) as f:
        f.create_dataset("t", data=trajs[0][0][:8])
    with open("v73.mat", "r+b") as f:
        block = header.ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02" + b"IM"
        f.write(block.ljust(512, b"\x00"))


if __name__ == "__main__":
    main()
