"""Tests of `ssm_ctl.simulate` and `ssm_ctl.stability` on the bundled scenes of plants
written as equations.

Independent references: the delayed sampled PD law recomputed from the returned columns
(the names and the alignment of `t`, the coordinates, their velocities and `u`), and the
closed-form zero-order-hold map of the single inverted pendulum's linearization with its
delayed-loop companion matrix, whose eigenvalues are the multipliers.
"""

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

import ssm_ctl as sc

SCENES = Path(__file__).resolve().parents[3] / "scenes"


def test_simulate_returns_the_csv_columns_and_obeys_the_control_law():
    r = sc.simulate("cartpole-pd", set={"run.periods": 40})
    assert list(r) == ["t", "theta", "theta_dot", "x", "x_dot", "u"]
    assert all(isinstance(v, np.ndarray) and v.shape == (41,) for v in r.values())
    dt = 0.010
    assert np.allclose(r["t"], dt * np.arange(41), rtol=0, atol=1e-12)
    # u_k = -sum_i [p_i q_i(k-1) + d_i (q_i(k-1) - q_i(k-2)) / dt]: the scene's gains, delay 1.
    scene = tomllib.loads((SCENES / "cartpole-pd.toml").read_text())
    gains = {q: (g["p"], g["d"]) for q, g in scene["controller"]["gains"].items()}
    assert set(gains) == {"theta", "x"}
    for k in range(2, 41):
        u = -sum(p * r[q][k - 1] + d * (r[q][k - 1] - r[q][k - 2]) / dt for q, (p, d) in gains.items())
        assert r["u"][k] == pytest.approx(u, rel=1e-12, abs=1e-12)
    assert r["theta"][0] == 0.05 and r["x"][0] == 0.0


def test_overrides_as_dict_list_and_numpy_scalars_agree():
    a = sc.simulate("pendulum-pd", set={"run.periods": 20, "plant.parameters.m": 0.25})
    b = sc.simulate("pendulum-pd", set=["run.periods=20", "plant.parameters.m=0.25"])
    c = sc.simulate("pendulum-pd", set={"run.periods": np.int64(20), "plant.parameters.m": np.float64(0.25)})
    d = sc.simulate("pendulum-pd", set={"run.periods": 20})
    for k in a:
        assert np.array_equal(a[k], b[k]) and np.array_equal(a[k], c[k])
    assert not np.array_equal(a["theta"], d["theta"])
    g = sc.simulate("cartpole-pd", set={"run.periods": 5, "controller.gains": {"theta": {"p": -45.0, "d": -7.0}}})
    assert list(g) == ["t", "theta", "theta_dot", "x", "x_dot", "u"]


def pendulum_multipliers(m=0.3, l=0.6, g=9.81, c=0.01, kp=3.0, kd=0.3, dt=0.020):
    """Closed-form ZOH of m l^2 theta'' = m g l theta - c theta' + u with u held, and the
    companion matrix of u_k = -kp y_(k-1) - kd (y_(k-1) - y_(k-2)) / dt."""
    j = m * l * l
    a = np.array([[0.0, 1.0], [g / l, -c / j]])
    b = np.array([0.0, 1.0 / j])
    w, v = np.linalg.eig(a)
    phi = (v @ np.diag(np.exp(w * dt)) @ np.linalg.inv(v)).real
    gam = np.linalg.solve(a, (phi - np.eye(2)) @ b)
    # State (theta_k, omega_k, theta_(k-1), theta_(k-2)); u_k from the two old samples.
    k1, k2 = -(kp + kd / dt), kd / dt
    mat = np.zeros((4, 4))
    mat[:2, :2] = phi
    mat[:2, 2] = gam * k1
    mat[:2, 3] = gam * k2
    mat[2, 0] = 1.0
    mat[3, 2] = 1.0
    return np.linalg.eigvals(mat)


def test_stability_equals_the_closed_form_zoh_multipliers():
    mu = sc.stability("pendulum-pd")
    assert mu.dtype == np.complex128 and mu.shape == (4,)
    assert np.all(np.diff(np.abs(mu)) <= 1e-15), "largest modulus first"
    for want in pendulum_multipliers():
        assert np.min(np.abs(mu - want)) < 1e-10 * max(1.0, abs(want)), (mu, want)
    mu2 = sc.stability("pendulum-pd", set={"controller.kp": 2.5, "plant.parameters.l": 0.5})
    for want in pendulum_multipliers(kp=2.5, l=0.5):
        assert np.min(np.abs(mu2 - want)) < 1e-10 * max(1.0, abs(want)), (mu2, want)


def test_bad_scenes_and_overrides_are_named_errors():
    with pytest.raises(ValueError, match="plant.mass"):
        sc.stability("pendulum-pd", set={"plant.parameters.l": 0})
    with pytest.raises(ValueError, match="controller.kp"):
        sc.stability("pendulum-pd", set={"controller.kp": "fast"})
    with pytest.raises(ValueError, match="thetaa"):
        sc.simulate("pendulum-pd", set={"plant.forces": ["m*g*l*sin(thetaa) + u"]})
    with pytest.raises(ValueError, match="no-such-scene"):
        sc.simulate("no-such-scene")
    with pytest.raises(ValueError, match="expected PATH=VALUE"):
        sc.stability("pendulum-pd", set=["controller.kp"])
    with pytest.raises(TypeError, match="scene"):
        sc.simulate(3)
    with pytest.raises(TypeError, match="set"):
        sc.stability("pendulum-pd", set=5)
    with pytest.raises(TypeError, match="controller.kp"):
        sc.stability("pendulum-pd", set={"controller.kp": object()})
    with pytest.raises(TypeError, match=r"set\[0\]"):
        sc.stability("pendulum-pd", set=[1.5])
    with pytest.raises(TypeError, match="keys"):
        sc.stability("pendulum-pd", set={1: 2})


def test_scene_paths(tmp_path):
    from pathlib import Path

    text = (Path(__file__).resolve().parents[3] / "scenes" / "pendulum-pd.toml").read_text()
    p = tmp_path / "mine.toml"
    p.write_text(text)
    assert np.array_equal(sc.stability(p), sc.stability("pendulum-pd"))
    assert math.isfinite(sc.simulate(str(p), set={"run.periods": 3})["u"][-1])
