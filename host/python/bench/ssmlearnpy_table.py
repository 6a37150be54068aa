"""SSMLearnPy with its sloshing example's settings on the data sets of the report's auto table.

    python host/python/bench/ssmlearnpy_table.py [--data-dir ../shared/data] [--write]

The settings of SSMLearnPy's examples/sloshing notebook: a 2D SSM, its default delay embedding
(`coordinates_embedding` with imdim = 2), a manifold of order 2, a polynomial flow of order 3.
The leading eigenvalue is that of the flow's linear part (`eigenvalues_linear_part`, computed
before any normal-form step, so the notebook's normal-form structure would not change it):
printed as damping ratio and frequency; with `--write` also written to
studies/results/auto/ssmlearnpy.json, which the report's auto table reads (rows it cannot run
say why). Needs only numpy, scipy and SSMLearnPy (not ssm_ctl): SSMLearnPy is not on PyPI,
install it from its source (github haller-group/SSMLearnPy; numpy 1.24.3, scikit-learn < 1.6).
The data set names match furuta::auto_sets. SSMLEARNPY_COMMIT, when set, is recorded as
the source's commit.
"""

import argparse
import json
import logging
import math
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
OUT = ROOT / "studies" / "results" / "auto" / "ssmlearnpy.json"
SETTINGS = "dim 2, embedding imdim 2, manifold order 2, flow order 3"


def csv(path, cols):
    with open(path) as f:
        head = f.readline().strip().split(",")
    a = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    idx = [head.index(c) for c in cols] if cols else list(range(1, len(head)))
    return a[:, 0], a[:, idx].T.copy()


def sets(data_dir):
    duff = ROOT / "host" / "ssm" / "tests" / "data"
    d = [csv(duff / f"duffing_{i}.csv", ["x"]) for i in (1, 2, 3)]
    out = [("Duffing CSVs (x, 3 decays)", d), ("Duffing CSV 1 alone (x)", d[:1])]
    from scipy.io import loadmat

    cells = loadmat(duff / "duffing.mat")["xData"]
    out.append(("Duffing .mat (3 observables, 3 decays)",
                [(np.squeeze(cells[i, 0]).astype(float), np.atleast_2d(cells[i, 1]).astype(float))
                 for i in range(cells.shape[0])]))
    slosh = data_dir / "sloshing"
    if all((slosh / f"decay_{i}.csv").is_file() for i in range(3)):
        out.append(("sloshing (3 measured decays)", [csv(slosh / f"decay_{i}.csv", None) for i in range(3)]))
    return out


def leading(trajs):
    from ssmlearnpy import SSMLearn

    ssm = SSMLearn(t=[t for t, _ in trajs], x=[x for _, x in trajs], ssm_dim=2, dynamics_type="flow")
    ssm.get_reduced_coordinates("linearchart")
    ssm.get_parametrization(poly_degree=2)
    ssm.get_reduced_dynamics(poly_degree=3)
    eig = np.asarray(ssm.reduced_dynamics.map_info["eigenvalues_linear_part"], dtype=complex)
    osc = [e for e in eig if e.imag > 0] or list(eig)
    e = max(osc, key=lambda v: v.real)
    return -e.real / abs(e), e.imag / (2 * math.pi)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data-dir", type=Path, default=ROOT.parent / "shared" / "data")
    ap.add_argument("--write", action="store_true")
    a = ap.parse_args()
    rows = []
    try:
        import ssmlearnpy

        status = "SSMLearnPy (github haller-group/SSMLearnPy)"
    except ImportError as e:
        status = (f"SSMLearnPy is not installed in this Python ({e}); it is not on PyPI, install it from its "
                  "source (github haller-group/SSMLearnPy)")
        ssmlearnpy = None
    if ssmlearnpy is not None and os.environ.get("SSMLEARNPY_COMMIT"):
        status += f" at commit {os.environ['SSMLEARNPY_COMMIT']}"
    logging.disable(logging.INFO)
    for name, trajs in sets(a.data_dir):
        if ssmlearnpy is None:
            rows.append({"set": name, "not_run": status})
            continue
        try:
            z, f = leading(trajs)
            rows.append({"set": name, "settings": SETTINGS, "damping_ratio": z, "freq_hz": f})
            print(f"{name}: damping ratio {z:.5f}, {f:.4f} Hz")
        except Exception as e:  # noqa: BLE001 - the row says why SSMLearnPy failed
            rows.append({"set": name, "not_run": f"SSMLearnPy failed: {type(e).__name__}: {e}"})
            print(f"{name}: failed: {e}")
    if a.write:
        OUT.parent.mkdir(parents=True, exist_ok=True)
        doc = {"command": "python host/python/bench/ssmlearnpy_table.py --write", "ssmlearnpy": status,
               "rows": rows}
        fd, tmp = tempfile.mkstemp(dir=OUT.parent, prefix=".ssmlearnpy.")
        with os.fdopen(fd, "w") as fh:
            fh.write(json.dumps(doc, indent=2) + "\n")
        os.replace(tmp, OUT)
        print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
