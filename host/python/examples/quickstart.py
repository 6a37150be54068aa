"""ssm_ctl quickstart: paste into a notebook (from the workspace root) or run
`python host/python/examples/quickstart.py`.

An SSMLearn-style workflow on the bundled Duffing data (a .mat file in SSMLearn's layout,
three observables): load, cut the initial transient, fit a 2D SSM model, predict a held-out
trajectory, read the normal form and the backbone curve, save the model, and plot when
matplotlib is installed.
"""

from pathlib import Path

import numpy as np

import ssm_ctl as sc

try:
    DATA = Path(__file__).resolve().parents[2] / "ssm" / "tests" / "data"
except NameError:  # pasted into a notebook: run from the workspace root
    DATA = Path("host/ssm/tests/data")

# SSMLearn's xData: one row {t, X} per trajectory; X one row per observable.
trajs = sc.load_mat(DATA / "duffing.mat")  # list of Trajectory (t: (n,), x: (n, q))
train, test = [trajs[0], trajs[2]], trajs[1].window(0.5)  # indTest = 2, cut t < 0.5 s

# The options of `ssmctl fit`: 2D SSM, 2 delayed copies of each observable, cubic manifold,
# 5th-order polynomial flow; t_from = SSMLearn's sliceTrajectories.
model = sc.fit(train, dim=2, embed=2, order=3, dyn_order=5, dynamics="flow", t_from=0.5)
print(model, f"fitted in {model.fit_seconds * 1e3:.1f} ms")
print("eigenvalues (1/s):", model.eigenvalues)  # exact: -0.125664 +- 6.281929i

pred = model.predict(test)  # pred.x: (n, 3), pred.t, pred.eta (reduced coordinates)
print(f"test NMTE over all observables: {pred.nmte(test):.2e}")

nf = model.normal_form()
for row in nf["table"]:
    print(f"rho_{row['mode']}'  {row['monomial']:<10} {row['value']:+.5f}")

amp_max = np.abs(np.concatenate([t.window(0.5).x[:, 0] for t in train])).max()
bb = model.backbone(amp_max, observable=0)[0]  # numpy arrays per mode
print(f"backbone: {bb['freq_rad_s'][0] / (2 * np.pi):.4f} Hz at 0 -> "
      f"{bb['freq_rad_s'][-1] / (2 * np.pi):.4f} Hz at amplitude {bb['amplitude'][-1]:.3f}")

model.save("duffing_model.json")  # ssmctl's saved-model format; sc.load_model(...) reads it

try:
    import matplotlib.pyplot as plt
except ImportError:
    print("matplotlib not installed: no plots")
else:
    fig, ax = plt.subplots(1, 3, figsize=(13, 3.5))
    ax[0].plot(test.t, test.x[:, 0], "k", label="data")
    ax[0].plot(pred.t, pred.x[:, 0], "r--", label="model")
    ax[0].set(xlabel="t [s]", ylabel="x", title="held-out trajectory")
    ax[0].legend()
    ax[1].plot(bb["freq_rad_s"] / (2 * np.pi), bb["amplitude"])
    ax[1].set(xlabel="frequency [Hz]", ylabel="amplitude of x", title="backbone")
    ax[2].plot(bb["damping_ratio"], bb["amplitude"])
    ax[2].set(xlabel="damping ratio", ylabel="amplitude of x", title="damping")
    fig.tight_layout()
    plt.show()
