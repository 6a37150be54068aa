"""ssm_ctl against SSMLearnPy: the same fit, timed in the same Python process.

    python host/python/bench/bench_ssmlearnpy.py [--data-dir ../shared/data] [--repeat 5]

The fit: a 2D SSM of the sloshing decays (train decay_0, decay_1; test decay_2; one
observable, 5 delay coordinates = SSMLearn's minimal embedding 2 d + 1), cubic manifold over
the tangent space (SVD, "linearchart"), polynomial flow of order 5, no ridge; then the
prediction of the test decay from its first point. Both libraries get the same arrays. Times
(the fit alone, and fit + prediction) are the median of `--repeat` runs after one warm-up;
the ratios are SSMLearnPy / ssm_ctl.
Without the sloshing data the bundled Duffing decays are used.

SSMLearnPy is not on PyPI (source: github haller-group/SSMLearnPy; it pins numpy 1.24.3 and
needs scikit-learn < 1.6): install it in the venv that has ssm_ctl, e.g.
`pip install git+https://github.com/haller-group/SSMLearnPy` or from a local checkout.
Where it is not installed the script says so and exits 0 (it is not part of the tests).
"""

import argparse
import logging
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import ssm_ctl as sc

ROOT = Path(__file__).resolve().parents[3]


def load_sets(data_dir):
    slosh = data_dir / "sloshing"
    if all((slosh / f"decay_{i}.csv").is_file() for i in range(3)):
        trajs = [sc.load_csv(slosh / f"decay_{i}.csv") for i in range(3)]
        return "sloshing decay_0, decay_1 -> decay_2", trajs[:2], trajs[2]
    duff = ROOT / "host" / "ssm" / "tests" / "data"
    trajs = [sc.load_csv(duff / f"duffing_{i}.csv", column="x") for i in (1, 3, 2)]
    return "Duffing x (sloshing data not found)", trajs[:2], trajs[2]


def nmte(pred, ref):
    """SSMLearn's NMTE: mean error norm over the max norm of the reference."""
    pred, ref = np.asarray(pred).reshape(len(ref), -1), np.asarray(ref).reshape(len(ref), -1)
    return float(np.mean(np.linalg.norm(pred - ref, axis=1)) / np.max(np.linalg.norm(ref, axis=1)))


def ours_fit(train):
    return sc.fit(train, dim=2, embed=5, order=3, dyn_order=5, dynamics="flow")


def ours(train, test):
    model = ours_fit(train)
    pred = model.predict(test)
    return model, pred.x[:, 0]


def theirs_fit(train):
    from ssmlearnpy import SSMLearn

    t = [tr.t for tr in train]
    x = [tr.x.T.copy() for tr in train]  # SSMLearnPy: (n_features, n_samples)
    ssm = SSMLearn(t=t, x=x, ssm_dim=2, dynamics_type="flow")
    ssm.get_reduced_coordinates("linearchart")
    ssm.get_parametrization(poly_degree=3)
    ssm.get_reduced_dynamics(poly_degree=5)
    return ssm


def theirs(train, test):
    from ssmlearnpy.geometry.coordinates_embedding import coordinates_embedding

    ssm = theirs_fit(train)
    t_emb, x_emb, _ = coordinates_embedding([test.t], [test.x.T.copy()], imdim=2)
    eta = ssm.encode(x_emb[0])
    red = ssm.predict_reduced_dynamics(t=t_emb, x_reduced=[eta])
    y = ssm.decode(red["reduced_coordinates"][0])
    return ssm, t_emb[0], y[0]


def timed(f, repeat):
    f()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = f()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data-dir", type=Path, default=ROOT.parent / "shared" / "data")
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args()
    b = sc.__build__
    print(f"ssm_ctl module: opt-level {b['opt_level']}, debug assertions "
          f"{'on' if b['debug_assertions'] else 'off'}, cargo profile folder `{b['profile']}`"
          + (" (UNOPTIMIZED: these times are not the library's; build with opt-level 2 or release)"
             if b["opt_level"] == "0" else ""))
    try:
        import ssmlearnpy  # noqa: F401
    except ImportError as e:
        print(f"bench skipped: SSMLearnPy is not installed in this Python ({e}). It is not on PyPI: "
              "pip install git+https://github.com/haller-group/SSMLearnPy (numpy 1.24.3, scikit-learn < 1.6).")
        return 0
    logging.disable(logging.INFO)  # SSMLearnPy logs every step at INFO
    label, train, test = load_sets(a.data_dir)
    print(f"data: {label}; {sum(len(t) for t in train)} training samples, {len(test)} test samples")
    f_ours, _ = timed(lambda: ours_fit(train), a.repeat)
    f_theirs, _ = timed(lambda: theirs_fit(train), a.repeat)
    t_ours, (model, y_ours) = timed(lambda: ours(train, test), a.repeat)
    t_theirs, (_, t_emb, y_theirs) = timed(lambda: theirs(train, test), a.repeat)
    # NMTE of each on the samples SSMLearnPy predicts (its embedding drops the last p - 1).
    ref = test.x[: len(t_emb), 0]
    print(f"ssm_ctl     fit {f_ours * 1e3:9.2f} ms, fit + predict {t_ours * 1e3:9.2f} ms, "
          f"test NMTE {nmte(y_ours[: len(ref)], ref):.4f}")
    print(f"SSMLearnPy  fit {f_theirs * 1e3:9.2f} ms, fit + predict {t_theirs * 1e3:9.2f} ms, "
          f"test NMTE {nmte(y_theirs, ref):.4f}")
    print(f"ratio SSMLearnPy / ssm_ctl (median of {a.repeat}): fit {f_theirs / f_ours:.1f}x, "
          f"fit + predict {t_theirs / t_ours:.1f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
