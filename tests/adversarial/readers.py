#!/usr/bin/env python3
"""Adversarial pass over every reader boundary of ssmctl: bounded reads, sizes checked
before allocating, bounded nesting, meaningless numbers and bad shard files refused.

usage: tests/adversarial/readers.py SSMCTL WORKDIR [--jobs N]   (REPO=checkout, default .)

Not part of `cargo xtask test` (minutes, hundreds of processes, a 3 GB sparse file): the
regression tests of each class are in host/ssmctl/tests/readers.rs, exit_codes.rs and the
fuzz targets. Shard edits here re-hash with Python's float text, which is not serde_json's,
so most are refused by the hash check; readers.rs re-hashes in Rust and reaches the
content checks.

Each case runs SSMCTL under a 4 GiB address-space limit and a 30 s timeout, and is
classified: ok-refused (exit 1/2 naming the input, in words), accepted (exit 0 where that is
legitimate), and the failure classes panic (101), abort (134/SIGABRT, incl. allocation
failure and stack overflow), signal (other signals), hang (timeout), over-4GB (allocation
failure under the limit), silent (exit 0 for an input that must be refused), unnamed (exit
1 without naming the file/option/key), debug-text (Rust Debug text or a bare `os error`).
"""
import json, os, random, re, shutil, signal, struct, subprocess, sys, zlib
from concurrent.futures import ThreadPoolExecutor

BIN, WORK = sys.argv[1], sys.argv[2]
JOBS = int(sys.argv[sys.argv.index("--jobs") + 1]) if "--jobs" in sys.argv else 2
REPO = os.path.dirname(os.path.abspath(__file__))
SRC = os.environ.get("REPO", ".")
os.makedirs(WORK, exist_ok=True)
rnd = random.Random(37)
cases = []  # (cls, name, args, must_refuse, names)


def P(*a):
    return os.path.join(WORK, *a)


def w(name, data):
    p = P(name)
    os.makedirs(os.path.dirname(p), exist_ok=True)
    with open(p, "wb" if isinstance(data, bytes) else "w") as f:
        f.write(data)
    return p


def add(cls, name, args, must_refuse=True, names=()):
    cases.append((cls, name, args, must_refuse, list(names)))


# ---- fixtures: a valid model JSON, blob, CSV, shard file
def run(args, **kw):
    return subprocess.run([BIN, "--quiet"] + args, capture_output=True, text=True, **kw)


sim = P("fx", "sim")
r = run(["simulate", "--scene", "furuta-quant-dt25", "--out", sim, "--set", "run.periods=400"])
assert r.returncode == 0, r.stderr
CSV = os.path.join(sim, "furuta-quant-dt25.csv")
MODEL = P("fx", "model.json")
r = run(["fit", "--data", CSV, "--column", "theta", "--dim", "2", "--embed", "5", "--dynamics", "rbf", "--centers", "20", "--save", MODEL])
assert r.returncode == 0, r.stderr
BLOB = P("fx", "model.bin")
r = run(["export", "--model", MODEL, "--out", BLOB])
assert r.returncode == 0, r.stderr
SPEC = w("fx/tiny.toml", 'name = "tiny"\nkind = "chart"\nscene = "furuta-dt25"\n[[axes]]\nname = "kd"\nlo = 0.0\nhi = 8.0\nn = 2\n[[axes]]\nname = "kp"\nlo = 0.0\nhi = 40.0\nn = 3\n')
r = run(["sweep", SPEC, "--out", P("fx", "shards")])
assert r.returncode == 0, r.stderr
SHARD = json.load(open(P("fx", "shards", "shard-000000-of-000001.json")))
MAT = os.path.join(SRC, "host/ssm/tests/data/duffing_plain.mat")
MATC = os.path.join(SRC, "host/ssm/tests/data/duffing.mat")

# ---- 1. file kinds at every reader
kinds = {}
fifo = P("k", "fifo")
os.makedirs(P("k"), exist_ok=True)
for n in ["fifo", "fifo.toml", "fifo.json", "fifo.csv", "fifo.mat", "fifo.bin"]:
    if not os.path.exists(P("k", n)):
        os.mkfifo(P("k", n))
os.makedirs(P("k", "dir.toml"), exist_ok=True)
if not os.path.exists(P("k", "zero-link")):
    os.symlink("/dev/zero", P("k", "zero-link"))
big = P("k", "sparse-3g")
with open(big, "wb") as f:
    f.truncate(3 << 30)
kinds = {
    "fifo": lambda ext: P("k", "fifo" + ext),
    "dev-zero": lambda ext: "/dev/zero",
    "dev-null": lambda ext: "/dev/null",
    "directory": lambda ext: P("k", "dir.toml"),
    "missing": lambda ext: P("k", "missing" + ext),
    "symlink-to-zero": lambda ext: P("k", "zero-link"),
    "sparse-3g": lambda ext: big,
}
readers = [
    ("fit --data", ".csv", lambda f: ["fit", "--data", f, "--column", "theta", "--dim", "2", "--embed", "5"]),
    ("fit --observables", ".csv", lambda f: ["fit", "--data", f, "--observables", "all", "--dim", "2", "--embed", "5"]),
    ("fit --test", ".csv", lambda f: ["fit", "--data", CSV, "--column", "theta", "--test", f, "--dim", "2", "--embed", "5"]),
    ("fit --mat", ".mat", lambda f: ["fit", "--mat", f, "--dim", "2", "--embed", "2"]),
    ("export --model", ".json", lambda f: ["export", "--model", f, "--out", P("o", "x.bin")]),
    ("backbone --model", ".json", lambda f: ["backbone", "--model", f, "--out", P("o", "bb"), "--amplitude", "0.1"]),
    ("frc --model", ".json", lambda f: ["frc", "--model", f, "--out", P("o", "frc"), "--freq-range", "1:2", "--calibrate", "1.5,0.1"]),
    ("inspect", ".bin", lambda f: ["inspect", f]),
    ("pil --model", ".bin", lambda f: ["pil", "--scene", "furuta-quant-dt25", "--model", f, "--periods", "5", "--out", P("o", "pil"), "--elf", BIN]),
    ("pil --elf", ".bin", lambda f: ["pil", "--scene", "furuta-quant-dt25", "--model", BLOB, "--periods", "5", "--out", P("o", "pil2"), "--elf", f]),
    ("--scene", ".toml", lambda f: ["stability", "--scene", f if f.endswith(".toml") or "dir" in f else f]),
    ("sweep SPEC", ".toml", lambda f: ["sweep", f, "--out", P("o", "sw")]),
    ("chaos --data", ".csv", lambda f: ["chaos", "--data", f]),
]
for rname, ext, mk in readers:
    for kname, path in kinds.items():
        f = path(ext)
        add("file-kind", f"{rname} <- {kname}", mk(f), True, [f, "--elf", "--model"])
# shard file that is a FIFO / device inside a merge folder
for kname in ["fifo", "dev-zero-link", "directory"]:
    d = P("merge-" + kname)
    os.makedirs(d, exist_ok=True)
    t = os.path.join(d, "shard-000000-of-000001.json")
    if not os.path.lexists(t):
        if kname == "fifo":
            os.mkfifo(t)
        elif kname == "directory":
            os.makedirs(t)
        else:
            os.symlink("/dev/zero", t)
    add("file-kind", f"sweep-merge <- {kname}", ["sweep-merge", d, "--out", P("o", "m-" + kname)], True, [t])

# ---- 2. .mat declared sizes, nesting, zlib
def mh():
    return b"MATLAB 5.0 MAT-file, adv".ljust(124, b" ") + struct.pack("<H", 0x0100) + b"IM"


def el(ty, data):
    return struct.pack("<II", ty, len(data)) + data + b"\0" * (-len(data) % 8)


def mx(cls, dims, name, rest=b""):
    return el(14, el(6, struct.pack("<II", cls, 0)) + el(5, b"".join(struct.pack("<i", d) for d in dims)) + el(1, name.encode()) + rest)


def comp(body):
    c = zlib.compress(body, 9)
    return struct.pack("<II", 15, len(c)) + c


mats = {
    "cell-2g-x-2g (184 B)": mh() + mx(1, [2**31 - 1, 2**31 - 1], "xData"),
    "double-2g-x-2g": mh() + mx(6, [2**31 - 1, 2**31 - 1], "xData", el(9, b"\0" * 8)),
    "cell-1e6-x-1": mh() + mx(1, [10**6, 1], "xData"),
    "dims-negative": mh() + mx(6, [-1, 5], "xData"),
    "dims-1000-of-them": mh() + mx(6, [1] * 1000, "xData"),
    "uint8-16M-for-1x1 (zlib)": mh() + comp(mx(6, [1, 1], "xData", el(2, b"\0" * (1 << 24)))),
    "12 vars x 64M inflated": mh() + comp(mx(6, [1, 1 << 23], "v", el(9, b"\0" * (8 << 23)))) * 12,
    "zlib truncated": mh() + comp(mx(6, [1, 1], "xData", el(9, b"\0" * 8)))[:-5],
    "zlib garbage": mh() + struct.pack("<II", 15, 64) + bytes(rnd.randrange(256) for _ in range(64)),
    "u8-1e8-doubles (zlib)": mh() + comp(mx(6, [1, 10**8 + 1], "xData", el(2, b"\0" * (10**8 + 1)))),
}
inner = mx(6, [0, 0], "")
for _ in range(30000):
    inner = mx(1, [1, 1], "", inner)
mats["cells nested 30000 deep (zlib)"] = mh() + comp(mx(1, [1, 1], "xData", inner))
inner = mx(6, [0, 0], "")
for _ in range(17):
    inner = mx(1, [1, 1], "", inner)
mats["cells nested 17 deep"] = mh() + mx(1, [1, 1], "xData", inner)
for n, b in mats.items():
    f = w("mat/" + re.sub(r"[^a-z0-9]+", "-", n.lower()) + ".mat", b)
    add("mat-size", n, ["fit", "--mat", f, "--dim", "2", "--embed", "2"], True, [f])
base = open(MAT, "rb").read()
for i in range(60):
    b = bytearray(base)
    for _ in range(rnd.randrange(1, 6)):
        b[128 + rnd.randrange(len(b) - 128)] = rnd.randrange(256)
    if i % 2:
        j = 128 + 4 + 8 * rnd.randrange((len(b) - 136) // 8)
        b[j : j + 4] = struct.pack("<i", rnd.choice([2**31 - 1, 2**30, 10**9, -1]))
    f = w(f"mat/mut{i}.mat", bytes(b))
    add("mat-mutation", f"duffing_plain mutation {i}", ["fit", "--mat", f, "--dim", "2", "--embed", "2"], False, [f])

# ---- 3. sweep specs
def spec(name, text):
    f = w("spec/" + name + ".toml", text)
    add("sweep-spec", name, ["sweep", f, "--out", P("o", "spec-" + name)], True, [f])


axis = lambda n: f'name = "s"\nkind = "chart"\nscene = "furuta-dt25"\n[[axes]]\nname = "kp"\nlo = 0.0\nhi = 40.0\nn = {n}\n[[axes]]\nname = "kd"\nlo = 0.0\nhi = 8.0\nn = 2\n'
for n in ["1000000000", "100000001", "9223372036854775807", "18446744073709551615", "0", "-1", "1e9"]:
    spec(f"axis-n-{n}", axis(n))
spec("two-axes-1e5-each", axis(100000).replace("n = 2", "n = 100000"))
spec("three-axes-product-overflow", axis(4000000000).replace("n = 2\n", 'n = 4000000000\n[[axes]]\nname = "dt_ms"\nlo = 20.0\nhi = 30.0\nn = 4000000000\n'))
spec("name-dotdot", axis(3).replace('name = "s"', 'name = "../../etc/x"'))
spec("name-slash", axis(3).replace('name = "s"', 'name = "a/b"'))
spec("name-empty", axis(3).replace('name = "s"', 'name = ""'))
spec("nested-100k", 'name = "s"\ndescription = ' + "[" * 100000 + "]" * 100000 + "\n")
spec("inline-tables-100k", 'name = "s"\nscene = ' + "{a=" * 100000 + "1" + "}" * 100000 + "\n")
spec("set-key-100k-deep", axis(3) + 'set = ["' + ".".join(["a"] * 100000) + '=1"]\n')
spec("set-value-nested", axis(3) + 'set = ["controller.kp=' + "[" * 100000 + '"]\n')
spec("values-dup", 'name = "s"\nkind = "basin"\nscene = "furuta-dt30.5"\n[basin]\nperiods = 10\n[[axes]]\nname = "theta0"\nvalues = [' + ", ".join(str(i * 1e-4) for i in range(50000)) + ", 0.0]\n")
spec("scene-fifo", axis(3).replace('scene = "furuta-dt25"', f'scene = "{P("k", "fifo.toml")}"'))
spec("scene-dev-zero", axis(3).replace('scene = "furuta-dt25"', 'scene = "/dev/zero"'))
spec("periods-huge", 'name = "s"\nkind = "basin"\nscene = "furuta-dt30.5"\n[basin]\nperiods = 18446744073709551615\n[[axes]]\nname = "theta0"\nvalues = [0.1]\n')
spec("chart-dt-axis-1000-panels", axis(3).replace("[[axes]]\nname = \"kd\"", '[[axes]]\nname = "dt_ms"\nlo = 20.0\nhi = 30.0\nn = 1000\n[[axes]]\nname = "kd"'))
spec("rtol-1e-300", axis(3) + 'set = ["integrator.rtol=1e-300"]\n')
spec("not-utf8", "name = \"s\xff\"\n")

# ---- 4. shard files
def h(v):
    # FNV-1a of the compact JSON text with sorted keys, as furuta::sweep::hash_value.
    t = json.dumps(v, separators=(",", ":"), sort_keys=True, ensure_ascii=False)
    x = 0xCBF29CE484222325
    for b in t.encode():
        x ^= b
        x = (x * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return f"{x:016x}"


def shard(name, edit, rehash=True, must=True):
    v = json.loads(json.dumps(SHARD))
    edit(v)
    if rehash:
        v["spec_hash"] = h(v["spec"])
    d = P("shard", name)
    os.makedirs(d, exist_ok=True)
    f = w(f"shard/{name}/shard-000000-of-000001.json", json.dumps(v))
    add("shard-file", name, ["sweep-merge", d, "--out", P("o", "merge-" + name)], must, [f])


def setp(path, val):
    def e(v):
        o = v
        for k in path[:-1]:
            o = o[k]
        o[path[-1]] = val
    return e


shard("name-dotdot", setp(["spec", "name"], "../../evil"))
shard("name-abs", setp(["spec", "name"], "/tmp/evil"))
shard("grid-value", setp(["spec", "axes", 1, "values", 1], 21.0))
shard("range-n-1e9", setp(["spec", "axes", 0, "range", "n"], 10**9))
shard("range-n-mismatch", setp(["spec", "axes", 0, "range", "n"], 3))
shard("axis-values-empty", setp(["spec", "axes", 0, "values"], []))
shard("axis-values-1e6", setp(["spec", "axes", 0, "values"], [0.0] * 10**6))
shard("kind-basin", setp(["spec", "kind"], "basin"))
shard("record-bounded", setp(["spec", "record"], ["bounded"]))
shard("record-empty", setp(["spec", "record"], []))
shard("cell-bounded", lambda v: (v["cells"][0].pop("kind"), v["cells"][0].__setitem__("bounded", True)))
shard("cell-values", setp(["cells", 0, "values"], [1.0, 2.0]))
shard("cell-index", setp(["cells", 0, "index"], 2**63))
shard("cells-total", setp(["cells_total"], 2**64 - 1))
shard("shard-count-0", setp(["shard", "count"], 0))
shard("shard-count-huge", setp(["shard", "count"], 4294967295))
shard("scene-dt-subnormal", setp(["spec", "scene", "controller", "dt_ms"], 5e-324))
shard("scene-name-path", setp(["spec", "scene", "name"], "../x"))
shard("format", setp(["spec", "format"], "other"))
shard("hash-stale", setp(["spec", "name"], "other"), rehash=False)
shard("axes-empty", setp(["spec", "axes"], []))
shard("axis-dup", lambda v: v["spec"]["axes"].append(v["spec"]["axes"][0]))
shard("nested-json", lambda v: None)
w("shard/nested-json/shard-000000-of-000001.json", "[" * 100000 + "]" * 100000)
for i in range(40):
    def e(v, i=i):
        ptrs = []
        def walk(o, p):
            if isinstance(o, dict):
                for k, x in o.items():
                    walk(x, p + [k])
            elif isinstance(o, list):
                ptrs.append(p)
                for k, x in enumerate(o[:20]):
                    walk(x, p + [k])
            elif isinstance(o, (int, float)) and not isinstance(o, bool):
                ptrs.append(p)
        walk(v, [])
        p = rnd.choice(ptrs)
        setp(p, rnd.choice([0, -1, 1e300, 10**12, 2**63, [], None, 0.5, 5e-324]))(v)
    shard(f"mutation-{i}", e, must=False)

# ---- 5. numbers and keys
sets = [
    ("integrator.rtol=1e-300", "integrator.rtol"), ("integrator.rtol=2", "integrator.rtol"),
    ("integrator.atol=1e-310", "integrator.atol"), ("controller.dt_ms=1e-310", "controller.dt_ms"),
    ("controller.dt_ms=5e-324", "controller.dt_ms"), ("effects.quantization.h_adc=1e-310", "h_adc"),
    ("effects.quantization.h_adc=1e300", "h_adc"), ("effects.quantization.h_dac=1e-310", "h_dac"),
    ("effects.quantization.h_adc_phi=1e-310", "h_adc_phi"), ("effects.saturation.u_max=1e-300", "u_max"),
    ("run.periods=18446744073709551615", "run.periods"), ("controller.delay=4294967295", "controller.delay"),
]
for kv, key in sets:
    add("numbers", "quant " + kv, ["stability", "--scene", "furuta-quant-dt25", "--set", kv], True, [key])
for kv, key in [("integrator.rtol=1e-300", "integrator.rtol"), ("integrator.atol=1e-300", "integrator.atol")]:
    add("numbers", "simulate " + kv, ["simulate", "--scene", "furuta-dt25", "--set", "run.periods=3", "--set", kv, "--out", P("o", "s1")], True, [key])
add("numbers", "rk4 steps 4e9", ["simulate", "--scene", "furuta-dt25", "--set", 'integrator={method="rk4", steps=4000000000}', "--set", "run.periods=2", "--out", P("o", "s2")], True, ["integrator.steps"])
add("numbers", "rk4 steps 1e6 x 1e7 periods", ["stability", "--scene", "furuta-dt25", "--set", 'integrator.method="rk4"', "--set", "integrator.steps=1000000", "--set", "run.periods=10000000"], False, ["integrator"])
for dt in ["1e5", "1e3", "300", "1e-300"]:
    add("numbers", f"ssm-equations dt_ms={dt}", ["ssm-equations", "--scene", "furuta-dt25", "--set", f"controller.dt_ms={dt}", "--order", "3"], True, ["dt"])
tiny = w("num/tiny-step.csv", "t,x\n" + "".join(f"{i*5e-324:e},{(i*0.3)%1}\n" for i in range(60)))
add("numbers", "csv subnormal step", ["fit", "--data", tiny, "--dim", "2", "--embed", "5"], True, [tiny])
m = json.load(open(MODEL))
for key, val in [("dt", 5e-324), ("dt", 1e-310)]:
    mm = json.loads(json.dumps(m))
    mm["model"][key] = val
    f = w(f"num/model-{key}-{val}.json", json.dumps(mm))
    add("numbers", f"model {key}={val}", ["export", "--model", f, "--out", P("o", "e.bin")], True, [f])
mm = json.loads(json.dumps(m))
dyn = mm["model"]["dynamics"]
k = list(dyn.keys())[0] if isinstance(dyn, dict) else None
if k and isinstance(dyn[k], dict) and "dt" in dyn[k]:
    dyn[k]["dt"] = dyn[k]["dt"] * 3
    f = w("num/model-dyn-dt-inconsistent.json", json.dumps(mm))
    add("numbers", "model dynamics dt 3x model dt", ["export", "--model", f, "--out", P("o", "e2.bin")], True, [f])

# ---- 6. option sizes and nesting
add("option-size", "stability-chart 1000 panels", ["stability-chart", "--scene", "furuta-dt25", "--out", P("o", "c.png"), "--dt-ms", ",".join(str(20 + i * 0.01) for i in range(1000))], True, ["--dt-ms"])
add("option-size", "frc N=1e12", ["frc", "--model", MODEL, "--out", P("o", "frc2"), "--freq-range", "1:2:1000000000000", "--calibrate", "1.5,0.1"], True, ["--freq-range"])
add("option-size", "set key 3e4 deep", ["stability", "--scene", "furuta-dt25", "--set", ".".join(["a"] * 30000) + "=1"], True, ["a.a"])
add("option-size", "set value nested 1e5", ["stability", "--scene", "furuta-dt25", "--set", "controller.kp=" + "[" * 100000], True, ["controller.kp"])
add("option-size", "set value inline tables 3e4", ["stability", "--scene", "furuta-dt25", "--set", "plant.params=" + "{a=" * 30000], True, ["plant.params"])
sc_deep = w("nest/deep.toml", 'name = "d"\ndescription = ' + "[" * 100000 + "]" * 100000 + "\n")
add("option-size", "scene nested 1e5", ["stability", "--scene", sc_deep], True, [sc_deep])
mj = w("nest/deep.json", "[" * 100000 + "]" * 100000)
add("option-size", "model json nested 1e5", ["export", "--model", mj, "--out", P("o", "n.bin")], True, [mj])
add("option-size", "backbone --model out/backbone.json --out out", None, True, ["backbone.json"])

# the backbone case: a real backbone result as the model, --out its own folder
bbdir = P("bbcase")
os.makedirs(bbdir, exist_ok=True)
r = run(["fit", "--data", CSV, "--column", "theta", "--dim", "2", "--embed", "5", "--dynamics", "map", "--save", P("bbcase", "m.json")])
r = run(["backbone", "--model", P("bbcase", "m.json"), "--out", bbdir, "--amplitude", "0.05"])
if not os.path.exists(P("bbcase", "backbone.json")):
    w("bbcase/backbone.json", '{"observable":"1","curves":[]}')
cases[-1] = ("option-size", "backbone --model out/backbone.json --out out", ["backbone", "--model", P("bbcase", "backbone.json"), "--out", bbdir, "--amplitude", "0.05"], True, ["backbone.json"])


# ---- run
DEBUG = re.compile(r"os error|Invalid \{|Some\(|None\b|Err\(|\{ what|Status|TINFL")


def one(c):
    cls, name, args, must, names = c
    before = os.path.getmtime(P("bbcase", "backbone.json"))
    try:
        p = subprocess.run(
            ["prlimit", f"--as={4 << 30}", "--", BIN, "--quiet"] + args,
            capture_output=True, text=True, timeout=30, errors="replace",
        )
        code, err = p.returncode, p.stderr
    except subprocess.TimeoutExpired:
        return (cls, name, "hang", "")
    if code == 101:
        verdict = "panic"
    elif code in (134, -6):
        verdict = "over-4GB" if "memory allocation" in err else "abort"
    elif code is not None and code < 0:
        verdict = f"signal-{-code}"
    elif code == 0:
        verdict = "silent" if must else "accepted"
    elif code in (1, 2):
        if DEBUG.search(err):
            verdict = "debug-text"
        elif not any(n in err for n in names) and not (code == 2 and "Usage" in err):
            verdict = "unnamed"
        else:
            verdict = "refused-ok"
    else:
        verdict = f"exit-{code}"
    if name.startswith("backbone --model out/") and os.path.getmtime(P("bbcase", "backbone.json")) != before:
        verdict = "input-overwritten"
    return (cls, name, verdict, err.strip().splitlines()[-1][:300] if err.strip() else "")


with ThreadPoolExecutor(JOBS) as ex:
    results = list(ex.map(one, cases))
from collections import Counter

by = Counter((r[0], r[2]) for r in results)
tot = Counter(r[2] for r in results)
print(json.dumps({"cases": len(results), "verdicts": tot, "by_class": {f"{a}/{b}": n for (a, b), n in sorted(by.items())}}, indent=1))
for r in results:
    if r[2] not in ("refused-ok", "accepted"):
        print(f"FAIL [{r[0]}] {r[1]}: {r[2]}: {r[3]}")
json.dump(results, open(os.path.join(WORK, "results.json"), "w"), indent=1)
