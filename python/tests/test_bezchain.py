"""The Python module against the CLI: each function's numbers equal `bezchain`'s on shipped data,
bad input raises the CLI's message as ValueError or OSError, long work releases the GIL, and the
type stubs name what the module holds."""

import ast
import json
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import bezchain


def read_csv_rows(path):
    return np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


# ---------------------------------------------------------------------------------------------
# Readers and generators.


def test_read_aerofoil_is_the_file(naca4413):
    pts = bezchain.read_aerofoil(naca4413)
    assert pts.shape == (82, 2) and pts.dtype == np.float64
    rows = [l.split() for l in naca4413.read_text().splitlines()[1:] if l.strip()]
    np.testing.assert_array_equal(pts, np.array(rows, dtype=float))
    assert np.array_equal(bezchain.read_aerofoil(str(naca4413)), pts)


def test_naca_equals_the_cli(cli, tmp_path):
    out = tmp_path / "n.dat"
    cli("naca", "4413", "--points", 161, "-o", out)
    pts = bezchain.naca("4413")
    assert pts.shape == (161, 2)
    # The Selig file holds 12 decimals.
    np.testing.assert_allclose(pts, bezchain.read_aerofoil(out), rtol=0, atol=5e-13)
    assert bezchain.naca("23012", points=82).shape == (82, 2)


def test_blade_equals_the_cli(cli, blade_json, tmp_path):
    out = tmp_path / "b.csv"
    cli("blade", blade_json, "-o", out)
    cloud = bezchain.blade(blade_json)
    assert cloud.shape == (984, 5)
    np.testing.assert_array_equal(cloud, read_csv_rows(out))
    small = bezchain.blade(blade_json, points_per_section=41, sections=4)
    assert small.shape == (164, 5)
    assert set(small[:, 3]) == {0, 1, 2, 3}


# ---------------------------------------------------------------------------------------------
# Fitting and the adaptive searches.


def test_fit_equals_the_cli_report(cli, naca4413, tmp_path):
    rep = tmp_path / "fit.json"
    cli("fit", naca4413, "--degree", 3, "--segments", 5, "--json", rep)
    want = json.loads(rep.read_text())
    chain = bezchain.fit(bezchain.read_aerofoil(naca4413), degree=3, segments=5)
    np.testing.assert_array_equal(chain.design_points, np.array(want["design_points"]))
    assert chain.sum_sq == want["offset"]["sum_sq"]
    assert chain.max_offset == want["offset"]["max"]
    got = json.loads(chain.to_json())
    for key in ("kind", "degree", "segments", "continuity", "breaks", "design_points", "control_points", "offset"):
        assert got[key] == want[key], key
    # Stamped as the CLI's, with the Python call as its command.
    for key in ("bezchain_version", "schema", "units"):
        assert got[key] == want[key], key
    assert got["command"][0] == "python" and got["command"][1].startswith("bezchain.fit(")
    assert (chain.degree, chain.segments, chain.continuity) == (3, 5, "C1")
    # The report reader takes the CLI's report back.
    back = bezchain.Chain.from_json(rep.read_text())
    np.testing.assert_array_equal(back.design_points, chain.design_points)
    assert back.max_offset == want["offset"]["max"]
    t = np.linspace(0, 1, 7)
    np.testing.assert_allclose(back.evaluate(t), chain.evaluate(t), rtol=0, atol=1e-15)
    assert chain.evaluate(0.0).shape == (2,)
    np.testing.assert_allclose(chain.evaluate(0.0), want["control_points"][0], atol=1e-15)
    np.testing.assert_allclose(chain.evaluate(1.0), want["control_points"][-1], atol=1e-15)
    assert chain.evaluate(np.zeros((3, 4))).shape == (3, 4, 2)


def test_adapt_equals_the_cli_report(cli, naca4413, tmp_path):
    rep = tmp_path / "adapt.json"
    cli("adapt", naca4413, "--tol", "1e-3", "--json", rep)
    want = json.loads(rep.read_text())
    chain = bezchain.adapt(bezchain.read_aerofoil(naca4413), 1e-3)
    assert chain.met == want["adapt"]["met"] and chain.met and chain.message is None
    np.testing.assert_array_equal(chain.design_points, np.array(want["design_points"]))
    assert chain.max_offset == want["offset"]["max"]
    got = json.loads(chain.to_json())
    assert got["adapt"]["encoding"] == want["adapt"]["encoding"]
    assert got["schema"] == want["schema"] == "bezchain.curve/1"
    back = bezchain.Chain.from_json(chain.to_json())
    np.testing.assert_array_equal(back.design_points, chain.design_points)


def test_adapt_surface_equals_the_cli_report(cli, blade_json, tmp_path):
    cloud_csv = tmp_path / "b.csv"
    cli("blade", blade_json, "--points-per-section", 41, "--sections", 4, "-o", cloud_csv)
    rep = tmp_path / "s.json"
    cli("adapt-surface", cloud_csv, "--tol", "5e-3", "--relative", "--degrees-u", "3-4", "--degrees-v", "2",
        "--quiet", "--json", rep)
    want = json.loads(rep.read_text())
    cloud = bezchain.blade(blade_json, points_per_section=41, sections=4)
    surf = bezchain.adapt_surface(cloud, 5e-3, relative=True, degrees_u="3-4", degrees_v=2)
    np.testing.assert_array_equal(surf.design_net, np.array(want["design_net"]))
    assert surf.max_offset == want["offset"]["max"]
    assert surf.met == want["adapt"]["met"]
    assert json.loads(surf.to_json())["adapt"]["encoding"] == want["adapt"]["encoding"]
    net = np.array(want["control_net"])
    np.testing.assert_allclose(surf.evaluate(0.0, 0.0), net[0, 0], atol=1e-12)
    np.testing.assert_allclose(surf.evaluate(1.0, 1.0), net[-1, -1], atol=1e-12)
    assert surf.evaluate(np.full(5, 0.5), np.linspace(0, 1, 5)).shape == (5, 3)
    # A cloud file is taken as the CLI takes it.
    from_file = bezchain.adapt_surface(cloud_csv, 5e-3, relative=True, degrees_u="3-4", degrees_v=2)
    np.testing.assert_array_equal(from_file.design_net, surf.design_net)


def test_adapt_surface_takes_the_clis_span_breaks(cli, blade_json, tmp_path):
    cloud_csv = tmp_path / "b.csv"
    cli("blade", blade_json, "--points-per-section", 41, "--sections", 4, "-o", cloud_csv)
    rep = tmp_path / "s.json"
    cli("adapt-surface", cloud_csv, "--tol", "5e-3", "--relative", "--degrees-u", "3-4", "--degrees-v", "2",
        "--span-breaks", "sections", "--quiet", "--json", rep)
    want = json.loads(rep.read_text())
    surf = bezchain.adapt_surface(cloud_csv, 5e-3, relative=True, degrees_u="3-4", degrees_v=2,
                                  span_breaks="sections")
    np.testing.assert_array_equal(surf.design_net, np.array(want["design_net"]))
    assert json.loads(surf.to_json())["adapt"]["encoding"] == want["adapt"]["encoding"]
    with pytest.raises(ValueError, match="span-break placement 'between'"):
        bezchain.adapt_surface(cloud_csv, 5e-3, relative=True, span_breaks="between")


# ---------------------------------------------------------------------------------------------
# Population evaluation.


def population(chain, n=16, seed=3, scale=2e-3):
    rng = np.random.default_rng(seed)
    base = chain.design_points.ravel()
    pop = base + scale * rng.standard_normal((n, base.size))
    pop[0] = base
    return pop


@pytest.mark.parametrize("backend", ["cpu", "gpu"])
def test_evaluator_equals_bezchain_eval(cli, naca4413, tmp_path, backend):
    rep = tmp_path / "fit.json"
    cli("fit", naca4413, "--degree", 3, "--segments", 5, "--json", rep)
    chain = bezchain.Chain.from_json(rep.read_text())
    pop = population(chain)
    popfile = tmp_path / "pop.csv"
    popfile.write_text("\n".join(",".join(repr(float(x)) for x in row) for row in pop) + "\n")
    p = cli("eval", rep, "--population", popfile, "--points", naca4413, "--backend", backend, check=False)
    if p.returncode != 0:
        if backend == "gpu":
            pytest.skip(f"no GPU adapter for the CLI: {p.stderr.strip()}")
        raise AssertionError(p.stderr)
    want = np.array([[float(v) for v in l.split(",")] for l in p.stdout.split()])
    ev = bezchain.Evaluator(chain, bezchain.read_aerofoil(naca4413), backend=backend)
    assert ev.n_vars == pop.shape[1]
    got = ev.evaluate(pop)
    assert got.shape == (16, 2)
    # The CLI prints the f32 fitness in shortest form: equal as f32.
    np.testing.assert_array_equal(got.astype(np.float32), want.astype(np.float32))
    assert backend in ev.info.lower()


def test_evaluator_on_a_surface_equals_bezchain_eval(cli, blade_json, tmp_path):
    cloud_csv = tmp_path / "b.csv"
    cli("blade", blade_json, "--points-per-section", 41, "--sections", 4, "-o", cloud_csv)
    rep = tmp_path / "s.json"
    cli("adapt-surface", cloud_csv, "--tol", "5e-3", "--relative", "--degrees-u", "3-4", "--degrees-v", "2",
        "--quiet", "--json", rep)
    cloud = bezchain.blade(blade_json, points_per_section=41, sections=4)
    surf = bezchain.adapt_surface(cloud, 5e-3, relative=True, degrees_u="3-4", degrees_v=2)
    base = surf.design_net.ravel()
    rng = np.random.default_rng(5)
    pop = base + 1e-3 * rng.standard_normal((6, base.size))
    pop[0] = base
    popfile = tmp_path / "pop.csv"
    popfile.write_text("\n".join(",".join(repr(float(x)) for x in row) for row in pop) + "\n")
    p = cli("eval", rep, "--population", popfile, "--points", cloud_csv, "--backend", "cpu")
    want = np.array([[float(v) for v in l.split(",")] for l in p.stdout.split()])
    got = bezchain.Evaluator(surf, cloud, backend="cpu").evaluate(pop)
    np.testing.assert_array_equal(got.astype(np.float32), want.astype(np.float32))


def test_evaluate_releases_the_gil(naca4413):
    chain = bezchain.fit(bezchain.read_aerofoil(naca4413))
    pts = bezchain.read_aerofoil(naca4413)
    ev = bezchain.Evaluator(chain, pts, backend="cpu")
    pop = population(chain, n=4000)
    ticks = []
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    time.sleep(0.01)
    start = time.perf_counter()
    ev.evaluate(pop)
    end = time.perf_counter()
    done.set()
    t.join()
    inside = [x for x in ticks if start < x < end]
    # Several ticks of the other thread while evaluate ran: it did not hold the GIL.
    assert end - start < 0.005 or len(inside) >= 3, (end - start, len(inside))


# ---------------------------------------------------------------------------------------------
# Aerodynamics.


def test_aero_equals_the_cli(cli, naca4413, tmp_path):
    rep = tmp_path / "aero.json"
    cli("aero", naca4413, "--alpha", "0,4,8", "--json", rep)
    want = json.loads(rep.read_text())
    for shape in (bezchain.read_aerofoil(naca4413), naca4413, str(naca4413)):
        got = bezchain.aero(shape, alpha=[0, 4, 8])
        assert list(got["cl"]) == [c["cl"] for c in want["polar"]]
        assert list(got["cm"]) == [c["cm"] for c in want["polar"]]
        np.testing.assert_array_equal(got["cp"], np.array([p["cp"] for p in want["pressure"]]))
        np.testing.assert_array_equal(got["nodes"], np.array(want["node_points"]))
        assert got["chord"] == want["chord"]["length"]
        assert got["trailing_edge"] == want["trailing_edge"]


def test_aero_of_a_chain_equals_the_cli_on_its_report(cli, naca4413, tmp_path):
    rep = tmp_path / "fit.json"
    cli("fit", naca4413, "--degree", 3, "--segments", 5, "--json", rep)
    out = tmp_path / "aero.json"
    cli("aero", rep, "--alpha", "2", "--json", out)
    want = json.loads(out.read_text())
    got = bezchain.aero(bezchain.Chain.from_json(rep.read_text()), alpha=[2.0])
    assert got["cl"][0] == want["polar"][0]["cl"]


def test_aero_viscous_equals_the_cli(cli, naca4413, tmp_path):
    rep = tmp_path / "polar.json"
    cli("aero", naca4413, "--re", "1e6", "--alpha", "0,4", "--json", rep)
    want = json.loads(rep.read_text())
    got = bezchain.aero(naca4413, alpha=[0, 4], re=1e6)
    assert list(got["converged"]) == [p["converged"] for p in want["polar"]] == [True, True]
    for key in ("alpha", "cl", "cd", "cdp", "cm", "xtr_top", "xtr_bottom"):
        assert list(got[key]) == [p[key] for p in want["polar"]], key
    assert got["re"] == want["re"] and got["ncrit"] == want["ncrit"]
    assert got["nodes"].shape == (want["nodes"], 2)


def test_aero_viscous_refuses_what_the_cli_refuses(naca4413):
    pts = bezchain.read_aerofoil(naca4413)
    with pytest.raises(ValueError, match="Reynolds number"):
        bezchain.aero(pts, alpha=[2.0], re=10.0)
    with pytest.raises(ValueError, match="Ncrit"):
        bezchain.aero(pts, alpha=[2.0], re=1e6, ncrit=0.0)
    with pytest.raises(ValueError, match="between -30 and 30"):
        bezchain.aero(pts, alpha=[45.0], re=1e6)


def test_optimise_equals_the_cli(cli, naca4413, tmp_path):
    rep = tmp_path / "opt.json"
    cli("optimise", naca4413, "--objective", "max-cl", "--min-thickness", 0.1, "--generations", 5, "--backend", "cpu",
        "--quiet", "--json", rep)
    want = json.loads(rep.read_text())
    got = bezchain.optimise(naca4413, "max-cl", min_thickness=0.1, generations=5, backend="cpu")
    np.testing.assert_array_equal(got["chain"].design_points, np.array(want["design_points"]))
    np.testing.assert_array_equal(got["design_points"], np.array(want["design_points"]))
    assert len(got["history"]["best"]) >= 5
    assert got["history"]["best"][-1] <= got["history"]["best"][0]
    assert got["cl"] > 1.0
    back = json.loads(got["chain"].to_json())
    assert back["design_points"] == want["design_points"]
    assert back["optimise"]["result"] == want["optimise"]["result"]
    assert "max-cl" in bezchain.objectives_list()


# ---------------------------------------------------------------------------------------------
# Errors: the CLI's messages, as ValueError or OSError.


def test_a_missing_file_is_an_oserror(cli, tmp_path):
    missing = tmp_path / "nope.dat"
    p = cli("fit", missing, "--degree", 3, "--segments", 5, check=False)
    with pytest.raises(OSError) as e:
        bezchain.read_aerofoil(missing)
    assert str(e.value) in p.stderr


def test_bad_arguments_are_valueerrors_with_the_cli_message(cli, naca4413):
    p = cli("naca", "12a", check=False)
    with pytest.raises(ValueError) as e:
        bezchain.naca("12a")
    assert str(e.value) in p.stderr
    p = cli("aero", naca4413, "--alpha", "120", check=False)
    assert p.returncode == 2
    with pytest.raises(ValueError) as e:
        bezchain.aero(naca4413, alpha=[120.0])
    assert str(e.value) in p.stderr
    p = cli("optimise", naca4413, "--objective", "max-lift", check=False)
    with pytest.raises(ValueError) as e:
        bezchain.optimise(naca4413, "max-lift")
    assert str(e.value) in p.stderr
    p = cli("adapt", naca4413, "--tol", "-1", check=False)
    with pytest.raises(ValueError) as e:
        bezchain.adapt(bezchain.read_aerofoil(naca4413), -1.0)
    assert str(e.value) in p.stderr
    with pytest.raises(ValueError, match="--segments 60"):
        bezchain.fit(bezchain.read_aerofoil(naca4413), degree=3, segments=60)
    with pytest.raises(ValueError, match="backend"):
        bezchain.Evaluator(bezchain.fit(bezchain.naca("0012")), bezchain.naca("0012"), backend="tpu")


def test_bad_arrays_are_valueerrors():
    with pytest.raises(ValueError, match="points"):
        bezchain.fit(np.zeros((10, 3)))
    with pytest.raises(ValueError, match="points"):
        bezchain.fit([[0.0, 0.0], [float("nan"), 1.0], [1.0, 1.0]])
    chain = bezchain.fit(bezchain.naca("0012"))
    ev = bezchain.Evaluator(chain, bezchain.naca("0012"))
    with pytest.raises(ValueError, match="design variables"):
        ev.evaluate(np.zeros((3, 5)))
    with pytest.raises(ValueError, match="outside"):
        chain.evaluate(1.5)
    with pytest.raises(ValueError, match="report"):
        bezchain.Chain.from_json('{"kind": "nothing"}')


# ---------------------------------------------------------------------------------------------
# The stubs.


def test_every_name_in_the_stubs_exists():
    stubs = Path(bezchain.__file__).with_name("_bezchain.pyi")
    tree = ast.parse(stubs.read_text())
    names = []
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            names.append(node.name)
            assert hasattr(bezchain, node.name), node.name
            if isinstance(node, ast.ClassDef):
                cls = getattr(bezchain, node.name)
                for item in node.body:
                    if isinstance(item, ast.FunctionDef) and not item.name.startswith("__"):
                        assert hasattr(cls, item.name), f"{node.name}.{item.name}"
        elif isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "__all__" for t in node.targets):
            assert sorted(ast.literal_eval(node.value)) == sorted(bezchain._bezchain.__all__)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            assert hasattr(bezchain._bezchain, node.target.id), node.target.id
    # ...and every public name of the module is in the stubs.
    for name in bezchain.__all__:
        assert name in names or name == "__version__", name
    assert Path(bezchain.__file__).with_name("py.typed").exists()


def test_stubtest_agrees_when_mypy_is_installed():
    pytest.importorskip("mypy")
    import subprocess
    import sys

    p = subprocess.run([sys.executable, "-m", "mypy.stubtest", "bezchain._bezchain"], capture_output=True, text=True)
    assert p.returncode == 0, p.stdout + p.stderr


def test_public_functions_have_docstrings():
    for name in bezchain.__all__:
        obj = getattr(bezchain, name)
        if callable(obj):
            assert obj.__doc__ and obj.__doc__.strip(), name
