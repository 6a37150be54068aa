"""Tests of the Python module `ssm_ctl` on the ssm crate's Duffing test data.

The data (host/ssm/tests/data, written by make_mat.py): a damped Duffing oscillator
x'' + 2 zeta w x' + w^2 x + k x^3 = 0, w = 2 pi rad/s, zeta = 0.02, k = 20, sampled every
0.02 s for 6 s from three amplitudes, observed through x, v and x + x^2/2. Exact references:
the linear eigenvalue -zeta w + i w sqrt(1 - zeta^2) and the backbone of the conservative
oscillator (period by quadrature). Tolerances are those of the Rust tests (ssmctl's fit
test: rate 1 %, frequency 1e-3 relative; mat_files.rs: test NMTE < 1e-2).
"""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import ssm_ctl as sc

DATA = Path(__file__).resolve().parents[2] / "ssm" / "tests" / "data"
W, ZETA, K = 2 * math.pi, 0.02, 20.0
EXACT = complex(-ZETA * W, W * math.sqrt(1 - ZETA**2))  # -0.125664 + 6.281929i


def mat(**kw):
    return sc.load_mat(DATA / "duffing.mat", **kw)


def csv(i, **kw):
    return sc.load_csv(DATA / f"duffing_{i}.csv", **kw)


def duffing_fit(**kw):
    """Train on trajectories 1 and 3, test on 2, first 0.5 s cut (the README's example)."""
    t = mat()
    opts = dict(order=3, dyn_order=5, t_from=0.5)
    opts.update(kw)
    return sc.fit([t[0], t[2]], dim=2, embed=2, **opts), t[1].window(0.5)


def test_mat_values_equal_the_csv_they_were_built_from():
    trajs = mat()
    assert len(trajs) == 3
    for i, tr in enumerate(trajs):
        c = csv(i + 1, observables="all")
        assert tr.observables == ["1", "2", "3"] and c.observables == ["x", "v", "x2"]
        assert tr.x.shape == (301, 3) and tr.t.shape == (301,) and len(tr) == 301
        assert np.array_equal(tr.t, c.t) and np.array_equal(tr.x, c.x)
        assert tr.name.endswith(f"xData{{{i + 1},:}}")
        assert tr.dt == pytest.approx(0.02, rel=1e-12)
    # Observable selection by .mat row number (1-based, as SSMLearn) or name.
    sel = mat(observables=[1, 3])[0]
    assert sel.observables == ["1", "3"]
    assert np.array_equal(sel.x, trajs[0].x[:, [0, 2]])
    assert np.array_equal(trajs[0].select("2").x[:, 0], trajs[0].x[:, 1])


def test_fit_recovers_the_exact_eigenvalue_and_predicts_the_test_trajectory():
    model, test = duffing_fit()
    assert model.observables == 3 and model.dim == 2
    assert model.dt == pytest.approx(0.02, rel=1e-12)
    assert model.fit_seconds > 0
    ev = model.eigenvalues
    assert ev.dtype == np.complex128 and ev.shape == (2,)
    lam = ev[np.argmax(ev.imag)]
    assert abs((lam.real - EXACT.real) / EXACT.real) < 0.01, lam
    assert abs((lam.imag - EXACT.imag) / EXACT.imag) < 1e-3, lam
    assert np.allclose(sorted(ev.imag), [-lam.imag, lam.imag], rtol=1e-12)
    pred = model.predict(test)
    assert pred.stopped is None
    assert pred.x.shape == (len(test), 3) and pred.t.shape == (len(test),)
    assert np.array_equal(pred.t, test.t)
    assert pred.eta.shape[1] == 2
    nmte = pred.nmte(test)
    assert 0 < nmte < 1e-2, nmte
    assert model.nmte(test) == nmte
    assert pred.nmte_dtw(test) <= nmte + 1e-12
    # The same trajectories from the CSV files: the same fit, the same NMTE.
    m2 = sc.fit([csv(1, observables=["x", "v", "x2"]), csv(3, observables="all")], dim=2, embed=2, t_from=0.5)
    assert m2.nmte(csv(2, observables="all").window(0.5)) == nmte


def test_trajectories_from_numpy_arrays_fit_like_files():
    tr = [mat()[i] for i in (0, 2)]
    arrays = [sc.Trajectory(t.t, t.x, observables=["x", "v", "x2"], name=f"run{i}") for i, t in enumerate(tr)]
    assert arrays[1].name == "run1" and arrays[0].observables == ["x", "v", "x2"]
    a = sc.fit(arrays, dim=2, embed=2, t_from=0.5)
    b, _ = duffing_fit()
    assert np.array_equal(a.eigenvalues, b.eigenvalues)
    # One observable as a 1-D array; integer lists are converted.
    one = sc.Trajectory(list(range(5)), [1, 3, 2, 5, 4])
    assert one.x.shape == (5, 1) and one.observables == ["1"] and one.x.dtype == np.float64


def test_windows_per_trajectory_and_their_errors():
    t = mat()
    m_all, _ = duffing_fit()
    # One value per trajectory (None: uncut) equals the same cut given once.
    m_each = sc.fit([t[0], t[2]], dim=2, embed=2, t_from=[0.5, 0.5])
    assert np.array_equal(m_each.eigenvalues, m_all.eigenvalues)
    w = t[0].window(1.0, 2.0)
    assert w.t[0] >= 1.0 and w.t[-1] <= 2.0 and len(w) == 51
    with pytest.raises(ValueError, match=r"t_from: 3 values for 2 trajectories"):
        sc.fit([t[0], t[2]], dim=2, embed=2, t_from=[0.5, 0.5, 0.5])
    with pytest.raises(ValueError, match=r"xData\{1,:\}: time window \[100, end\]: the window lies outside the data"):
        sc.fit([t[0], t[2]], dim=2, embed=2, t_from=100)
    with pytest.raises(ValueError, match="lies outside the data"):
        t[0].window(start=7.0)


def test_normal_form_and_backbone_against_the_conservative_duffing():
    model, _ = duffing_fit(dynamics="flow")
    nf = model.normal_form()
    assert nf["modes"] == 1 and nf["order"] >= 3
    lam = model.eigenvalues[np.argmax(model.eigenvalues.imag)]
    table = {r["monomial"]: r["value"] for r in nf["table"]}
    assert table["rho_1"] == pytest.approx(lam.real, rel=1e-9)
    assert nf["phase"][0][0] == pytest.approx(lam.imag, rel=1e-9)
    assert "rho_1^3" in table
    # Backbone: frequency against the amplitude of x (observable 0) through the manifold.
    curves = model.backbone(0.4, observable=0)
    assert len(curves) == 1
    c = curves[0]
    assert c["mode"] == 1 and c["observable"] == 0
    assert c["amplitude"].shape == (101,)
    assert c["amplitude"][0] == 0 and c["amplitude"][-1] == pytest.approx(0.4, abs=1e-9)
    assert c["freq_rad_s"][0] == pytest.approx(lam.imag, rel=1e-9)
    assert np.allclose(c["damping_ratio"][0], -lam.real / abs(lam), rtol=1e-9)

    def exact_freq(a):  # conservative Duffing: period by quadrature (x = a sin phi)
        phi = np.linspace(0, np.pi / 2, 4001)
        f = 1 / np.sqrt(W**2 + K / 2 * a**2 * (1 + np.sin(phi) ** 2))
        return 2 * np.pi / (4 * np.sum((f[1:] + f[:-1]) / 2 * np.diff(phi)))  # trapezoid

    for k in (25, 50, 75, 100):
        a, got = c["amplitude"][k], c["freq_rad_s"][k]
        want = exact_freq(a) * math.sqrt(1 - ZETA**2)
        print(f"backbone at amplitude {a:.3f}: frequency error {abs(got - want) / want:.2e} relative", file=sys.stderr)
        assert abs(got - want) / want < 1e-3, (a, got, want)
        # Weak linear damping (first-order averaging): decay rate zeta w at every amplitude,
        # damping ratio zeta w / |lambda| with |lambda|^2 = (zeta w)^2 + Omega(a)^2.
        zeta = ZETA * W / math.hypot(ZETA * W, exact_freq(a))
        assert abs(c["damping_ratio"][k] - zeta) / zeta < 0.01, (a, c["damping_ratio"][k], zeta)
    # Hardening: the frequency grows with the amplitude.
    assert np.all(np.diff(c["freq_rad_s"]) > 0)



def test_joint_anchor_recovers_the_exact_damping():
    # README's `--linear-anchor 0.5 --anchor-joint`: the rate much closer to the exact one
    # than without the anchor, and far closer than with the plain anchor.
    model, _ = duffing_fit(linear_anchor=0.5, anchor_joint=True)
    lam = model.eigenvalues[np.argmax(model.eigenvalues.imag)]
    print(f"joint anchor: eigenvalue {lam} (exact {EXACT})", file=sys.stderr)
    assert abs(lam.real - EXACT.real) / abs(EXACT.real) < 2e-4, lam
    assert abs(lam.imag - EXACT.imag) / EXACT.imag < 1e-3, lam


def test_forced_response_obeys_the_forced_normal_form():
    # README's `ssmctl frc` example: the same fit, calibrated at 6.25 rad/s, amplitude 0.32.
    model, _ = duffing_fit()
    r = model.forced_response(5.8, 6.9, 6.25, 0.32)
    cal = r["calibration"]
    assert cal["freq_rad_s"] == 6.25 and cal["amplitude"] == pytest.approx(0.32, rel=1e-9)
    assert cal["forcing"] == pytest.approx(6.37119e-2, rel=1e-5)  # what the CLI prints
    # Every steady state satisfies the forced polar normal form
    # f = rho sqrt(A(rho)^2 + (w(rho) - Omega)^2), A and w read off the backbone's rate and
    # frequency at that rho (the backbone is the f = 0 curve).
    bb = model.backbone(r["amplitude_max"], points=2001)[0]
    f = cal["forcing"]
    stable = [b for b in r["branches"] if b["stable"]]
    unstable = [b for b in r["branches"] if not b["stable"]]
    assert len(stable) == 2 and len(unstable) == 1  # hysteresis: two stable branches and a saddle branch
    for b in r["branches"]:
        assert b["freq_rad_s"].shape == b["amplitude"].shape == b["rho"].shape
        rate = np.interp(b["rho"], bb["rho"], bb["rate"])
        w = np.interp(b["rho"], bb["rho"], bb["freq_rad_s"])
        resid = b["rho"] * np.hypot(rate, w - b["freq_rad_s"]) - f
        assert np.max(np.abs(resid)) < 1e-3 * f, np.max(np.abs(resid))
    lo = min(b["freq_rad_s"].min() for b in r["branches"])
    hi = max(b["freq_rad_s"].max() for b in r["branches"])
    assert lo == pytest.approx(5.8) and hi == pytest.approx(6.9)
    for bad in (dict(calibrate_freq=-1.0), dict(calibrate_amplitude=0.0), dict(calibrate_amplitude=10.0), dict(freq_min=7.0)):
        args = dict(freq_min=5.8, freq_max=6.9, calibrate_freq=6.25, calibrate_amplitude=0.32)
        args.update(bad)
        with pytest.raises(ValueError):
            model.forced_response(**args)


def test_saved_model_json_round_trip(tmp_path):
    model, test = duffing_fit()
    text = model.to_json()
    assert '"format":"ssm-model"' in text.replace(" ", "")
    again = sc.Model.from_json(text)
    assert again.fit_seconds is None
    assert np.array_equal(again.eigenvalues, model.eigenvalues)
    # serde_json parses floats to within an ulp (not bit for bit: its `float_roundtrip`
    # feature is off), so the reloaded model agrees to rounding; a second trip is exact.
    x, y = model.predict(test).x, again.predict(test).x
    assert np.max(np.abs(x - y)) <= 1e-13 * np.max(np.abs(x))
    assert again.to_json() == sc.Model.from_json(again.to_json()).to_json()
    path = tmp_path / "m.json"
    model.save(path)
    loaded = sc.load_model(path)
    assert loaded.options == model.options and loaded.options["dim"] == 2
    assert np.array_equal(loaded.predict(test).x, y)
    with pytest.raises(ValueError, match="not a saved SSM model"):
        sc.Model.from_json('{"format": "other"}')
    with pytest.raises(ValueError, match="version"):
        sc.Model.from_json(text.replace('"version":1', '"version":9').replace('"version": 1', '"version": 9'))


def test_device_blob_round_trip():
    x = [t.select(1) for t in mat()]
    model = sc.fit([x[0], x[2]], dim=2, embed=5, dynamics="rbf", centers=40)
    blob = model.device_blob()
    assert isinstance(blob, bytes) and blob[:4] == b"SSMR"
    info = sc.inspect_blob(blob)
    assert info["bytes"] == len(blob) == 22 + info["payload_bytes"]
    assert (info["p"], info["d"], info["centres"], info["format_version"]) == (5, 2, 40, 2)
    assert info["sample_period_s"] == pytest.approx(0.02, rel=1e-6)
    bad = bytearray(blob)
    bad[-1] ^= 0xFF
    with pytest.raises(ValueError, match="(?i)crc"):
        sc.inspect_blob(bytes(bad))
    with pytest.raises(ValueError, match="blob"):
        sc.inspect_blob(b"nope")
    # Only RBF models of one observable go to the device.
    poly, _ = duffing_fit()
    with pytest.raises(ValueError, match="embeds one observable; this model has 3"):
        poly.device_blob()
    flow = sc.fit([x[0], x[2]], dim=2, embed=5, dynamics="flow")
    with pytest.raises(ValueError, match="only RBF reduced dynamics"):
        flow.device_blob()


def test_bad_input_is_a_value_error_naming_it():
    t = mat()
    cases = [
        (lambda: sc.load_mat(DATA / "no_such_file.mat"), "no_such_file.mat: cannot read"),
        (lambda: sc.load_mat(DATA / "v73.mat"), r"v7\.3 \(HDF5\).*'-v7'"),
        (lambda: sc.load_mat(DATA / "duffing.mat", var="yData"), "variables: xData"),
        (lambda: sc.load_mat(DATA / "mismatch.mat"), r"xData\{2,:\}"),
        (lambda: sc.load_mat(DATA / "duffing.mat", observables=[4]), "no observable `4`"),
        (lambda: csv(2, observables=["x", "w"]), "no column `w`"),
        (lambda: csv(2, observables="all", column="x"), "not both"),
        (lambda: sc.fit(t, dim=2, embed=2, dynamics="spline"), "dynamics `spline`: expected flow, map or rbf"),
        (lambda: sc.fit(t, dim=2, embed=2, ridge=-1), "ridge `-1`"),
        (lambda: sc.fit(t, dim=2, embed=2, ridge="loo"), "ridge `loo`"),
        (lambda: sc.fit([x.select(1) for x in t], dim=2, embed=4), r"must exceed 2 d = 4 \(Takens\)"),
        (lambda: sc.fit([t[0], t[1].select([1, 2])], dim=2, embed=2), "differ from those of"),
        (lambda: sc.fit([], dim=2, embed=2), "train: no trajectories"),
        (lambda: sc.fit(t, dim=2, embed=2, linear_anchor=2.0), "linear_anchor"),
        (lambda: sc.Trajectory(t[0].t, t[0].x.T), r"samples go along the first axis, shape \(301, q\)"),
        (lambda: sc.Trajectory(t[0].t, t[0].x, observables=["a"]), "1 observable names for 3 columns"),
        (lambda: sc.Trajectory([0, 1, 2], [1, 1, 1]), "constant"),
        (lambda: sc.Trajectory([0, 1, 3], [1, 2, 1]), "uneven sampling"),
        (lambda: sc.load_model(DATA / "duffing_1.csv"), "duffing_1.csv"),
    ]
    for call, want in cases:
        with pytest.raises(ValueError, match=want):
            call()
    model, test = duffing_fit()
    with pytest.raises(ValueError, match="1 observables, the model was fitted to 3"):
        model.predict(test.select(1))
    with pytest.raises(ValueError):
        model.backbone(-1.0)


def test_auto_fit_chooses_settings_and_gives_intervals():
    # The three trajectories of x alone; auto=True chooses the settings (dimension 2 from the
    # singular values) and bootstraps intervals that are narrow around the exact damping.
    t = [x.select(1) for x in mat()]
    model = sc.fit(t, auto=True, budget=12, replicates=40, backbone_amplitude=0.3)
    sel = model.selection
    assert sel["dim"]["dim"] == 2
    assert sel["evaluated"] <= 12
    assert sel["best"]["score"] <= sel["runner_up"]["score"]
    assert any(r.startswith("dimension 2") for r in sel["reasons"])
    iv = model.intervals
    assert iv["replicates"] == 40 and iv["failed"] == 0
    lam = iv["eigenvalues"][0]
    assert lam["re"]["lo"] <= lam["re"]["estimate"] <= lam["re"]["hi"]
    assert abs(lam["re"]["estimate"] - EXACT.real) / abs(EXACT.real) < 0.01, lam
    assert abs(lam["damping_ratio"]["estimate"] - ZETA) / ZETA < 0.01, lam
    band = iv["backbone"][0]
    assert len(band["amplitude"]) == len(band["freq_rad_s"]) == 41
    assert all(b["lo"] <= b["hi"] for b in band["freq_rad_s"])
    # The same data give the same choice.
    again = sc.fit(t, auto=True, budget=12, intervals=False)
    assert again.selection["best"] == sel["best"] and again.intervals is None
    # Without auto the intervals are opt-in.
    plain = sc.fit(t, dim=2, embed=5, intervals=True, replicates=20)
    assert plain.selection is None and plain.intervals["replicates"] == 20


def test_auto_bad_input_is_a_value_error_naming_it():
    t = [x.select(1) for x in mat()]
    with pytest.raises(ValueError, match="embed: auto=True chooses it"):
        sc.fit(t, auto=True, embed=5)
    with pytest.raises(ValueError, match="dim and embed are required"):
        sc.fit(t)
    with pytest.raises(ValueError, match="too little data for the cross-validation folds"):
        sc.fit(t[0].window(0.0, 1.0), auto=True)
    with pytest.raises(ValueError, match="replicates"):
        sc.fit(t, dim=2, embed=5, intervals=True, replicates=3)


def test_build_info_says_how_the_module_was_compiled():
    b = sc.__build__
    assert set(b) == {"opt_level", "debug", "profile", "debug_assertions"}
    assert b["opt_level"] in {"0", "1", "2", "3", "s", "z"}
    assert b["profile"] in {"debug", "release"}
    assert isinstance(b["debug_assertions"], bool)
