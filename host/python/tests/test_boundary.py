"""The Python boundary: wrong types raise TypeError, wrong values
ValueError (as numpy does), complex and object arrays are refused rather than cast, huge
shapes are refused before anything is copied, hostile files are errors, and no input reaches
the interpreter as a Rust panic (PanicException) or a crash.
"""

import struct
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest

import ssm_ctl as sc

DATA = Path(__file__).resolve().parents[2] / "ssm" / "tests" / "data"
T = np.arange(200) * 0.01
X = np.sin(2 * np.pi * T) * np.exp(-T)


def mat_header():
    b = b"MATLAB 5.0 MAT-file, boundary test".ljust(124, b" ")
    return b + struct.pack("<H", 0x0100) + b"IM"


def element(ty, data):
    return struct.pack("<II", ty, len(data)) + data + b"\0" * (-len(data) % 8)


def matrix(cls, dims, name, rest=b""):
    body = element(6, struct.pack("<II", cls, 0)) + element(5, b"".join(struct.pack("<i", d) for d in dims))
    return element(14, body + element(1, name.encode()) + rest)


def test_wrong_types_are_type_errors():
    t = sc.Trajectory(T, X)
    cases = [
        (lambda: sc.Trajectory(T, X.astype(complex)), "complex numbers"),
        (lambda: sc.Trajectory(T.astype(complex), X), "t: an array of complex"),
        (lambda: sc.Trajectory(T, np.array([object()] * len(T))), "Python objects"),
        (lambda: sc.Trajectory(T, ["a"] * len(T)), "strings"),
        (lambda: sc.Trajectory(T, X > 0), "booleans"),
        (lambda: sc.Trajectory(T, {"a": 1}), "x: "),
        (lambda: sc.Trajectory(T, None), "x: "),
        (lambda: sc.fit([1.0], dim=2, embed=2), "is not a Trajectory"),
        (lambda: sc.fit(3, dim=2, embed=2), "expected a Trajectory or a list"),
        (lambda: sc.fit(t, dim=2, embed=5, ridge=[1]), "ridge"),
        (lambda: sc.fit(t, dim=2, embed=5, t_from="x"), "t_from"),
        (lambda: sc.fit(t, dim="2", embed=5), "cannot be interpreted as an integer"),
        (lambda: t.select(1.5), "observables"),
    ]
    for call, want in cases:
        with pytest.raises(TypeError, match=want):
            call()


@pytest.mark.skipif(sys.version_info < (3, 11), reason="exception notes (PEP 678) need Python 3.11")
def test_a_wrong_argument_type_names_the_argument():
    # pyo3 names the argument in a note on the TypeError, which a traceback prints below it.
    t = sc.Trajectory(T, X)
    cases = [
        (dict(dim="2", embed=5), "dim"),
        (dict(dim=2, embed=5, shift="x"), "shift"),
        (dict(dim=2, embed=5, dynamics=3), "dynamics"),
        (dict(dim=2.5, embed=5), "dim"),
    ]
    for kwargs, name in cases:
        with pytest.raises(TypeError) as raised:
            sc.fit(t, **kwargs)
        notes = getattr(raised.value, "__notes__", [])
        assert f"while processing '{name}'" in notes, (kwargs, notes)


def test_wrong_values_are_value_errors():
    t = sc.Trajectory(T, X)
    cases = [
        (lambda: sc.Trajectory(T, X[:10]), "shape"),
        (lambda: sc.Trajectory(T, X * np.nan), "finite"),
        (lambda: sc.fit(t, dim=2, embed=5, ridge=-1.0), "ridge"),
        (lambda: sc.fit(t, dim=100, embed=5), "dim"),
        (lambda: sc.fit(t, dim=2, embed=10**9), "embed"),
        (lambda: sc.Trajectory(T * 1e-320, X), "time axis"),
    ]
    for call, want in cases:
        with pytest.raises(ValueError, match=want):
            call()


def test_huge_shapes_are_refused_before_copying():
    # Views of a few bytes claiming 10^12 and 2^58 values: refused by shape, not by memory.
    big = np.broadcast_to(np.float64(0.0), (10**6, 10**6))
    with pytest.raises(ValueError, match="more than 100000000 values"):
        sc.Trajectory(big[0], big)
    huge = np.lib.stride_tricks.as_strided(np.zeros(1), shape=(2**29, 2**29), strides=(0, 0))
    with pytest.raises(ValueError, match="more than 100000000 values"):
        sc.Trajectory(T, huge)


def test_hostile_files_are_value_errors(tmp_path):
    bomb = tmp_path / "bomb.mat"
    bomb.write_bytes(mat_header() + matrix(1, [2**31 - 1, 2**31 - 1], "xData"))
    assert bomb.stat().st_size == 184
    with pytest.raises(ValueError, match="4611686014132420609 entries"):
        sc.load_mat(bomb)
    inner = matrix(6, [0, 0], "")
    for _ in range(3000):
        inner = matrix(1, [1, 1], "", inner)
    deep = tmp_path / "deep.mat"
    payload = zlib.compress(matrix(1, [1, 1], "xData", inner), 9)
    deep.write_bytes(mat_header() + struct.pack("<II", 15, len(payload)) + payload)
    with pytest.raises(ValueError, match="nested more than 16 deep"):
        sc.load_mat(deep)
    fifo = tmp_path / "fifo.csv"
    import os

    os.mkfifo(fifo)
    for call in (lambda: sc.load_csv(fifo), lambda: sc.load_mat(fifo), lambda: sc.load_model(fifo)):
        with pytest.raises(ValueError, match="FIFO"):
            call()
    with pytest.raises(ValueError, match="character device"):
        sc.load_model("/dev/zero")
    with pytest.raises(ValueError, match="directory"):
        sc.load_csv(tmp_path)
    deep_json = tmp_path / "deep.json"
    deep_json.write_text("[" * 100000 + "]" * 100000)
    with pytest.raises(ValueError, match="deep.json"):
        sc.load_model(deep_json)


def test_options_that_size_work_are_bounded():
    t = sc.load_mat(DATA / "duffing.mat")
    model = sc.fit([t[0], t[2]], dim=2, embed=2, order=3, dyn_order=5, t_from=0.5)
    with pytest.raises(ValueError, match="points"):
        model.backbone(0.5, points=10**12)
    with pytest.raises(ValueError, match="points"):
        model.forced_response(5.8, 6.9, 6.25, 0.32, points=10**12)
    with pytest.raises(OverflowError):
        model.backbone(0.5, points=-1)
    with pytest.raises(ValueError):
        model.backbone(float("nan"))
    with pytest.raises(ValueError):
        sc.inspect_blob(b"\x00" * 10)
    with pytest.raises(ValueError):
        sc.Model.from_json("{" * 10000)


def test_no_panic_reaches_python():
    # Every call of the module runs behind a panic guard: sweep the API with odd inputs and
    # require that whatever is raised is one of the documented classes.
    t = sc.load_mat(DATA / "duffing.mat")
    model = sc.fit([t[0], t[2]], dim=2, embed=2, order=3, dyn_order=5, t_from=0.5)
    pred = model.predict(t[1])
    short = sc.Trajectory(T[:3], X[:3])
    calls = [
        lambda: model.predict(short),
        lambda: model.nmte(short),
        lambda: pred.nmte(short),
        lambda: pred.nmte_dtw(short, band=0),
        lambda: pred.nmte_dtw(t[1], band=10**18),
        lambda: model.normal_form(order=0),
        lambda: model.normal_form(order=10**9),
        lambda: model.backbone(1e300),
        lambda: model.backbone(0.5, observable=10**9),
        lambda: model.forced_response(1e-300, 1e300, 1.0, 1.0),
        lambda: model.forced_response(5.8, 6.9, 6.25, 0.32, mode=10**9),
        lambda: t[0].window(1e300, -1e300),
        lambda: t[0].select([]),
        lambda: sc.fit(t, dim=2, embed=2, shift=10**9),
        lambda: sc.fit(t, dim=2, embed=2, dynamics="rbf", centers=0),
        lambda: sc.fit(t, dim=2, embed=2, dynamics="rbf:gaussian:nan"),
        lambda: sc.fit([short], dim=1, embed=2),
    ]
    for call in calls:
        try:
            call()
        except (ValueError, TypeError, OverflowError):
            pass
        except BaseException as e:  # PanicException derives from BaseException
            pytest.fail(f"{type(e).__name__} reached Python: {e}")
