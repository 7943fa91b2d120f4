"""Maps: construction from arrays, evaluation and rasters against the C++ results."""

import numpy as np
import pytest

import potmap


def write_test_csv(points, path):
    pos, lab = points.positions, points.labels
    with open(path, "w") as f:
        f.write("t,x,y,occupied\n")
        for (x, y), l in zip(pos, lab):
            f.write(f"0,{x!r},{y!r},{int(l)}\n")


def test_construct_from_arrays_round_trips(rng):
    pos = rng.uniform(-5, 5, (40, 2))
    g = rng.uniform(0.5, 2, 40)
    wm = rng.normal(size=40)
    wv = rng.uniform(0.1, 1, 40)
    m = potmap.KernelMap(pos, g, wm, wv, bias=(0.5, 2.0))
    assert m.dim == 2 and len(m) == 40
    np.testing.assert_array_equal(m.positions, pos)
    np.testing.assert_array_equal(m.gamma, g)
    np.testing.assert_array_equal(m.w_mean, wm)
    np.testing.assert_array_equal(m.w_var, wv)
    assert m.bias == (0.5, 2.0)
    m32 = potmap.KernelMap(pos.astype(np.float32), g.astype(np.float32), wm, wv)
    np.testing.assert_array_equal(m32.positions, pos.astype(np.float32).astype(np.float64))
    assert m32.bias is None
    assert m.cutoff_tau == float("inf")


def test_a_cutoff_travels_with_the_map_and_is_evaluated_at(scene, ctx, rng, tmp_path):
    m = potmap.KernelMap(scene.map.positions, scene.map.gamma, scene.map.w_mean, scene.map.w_var)
    pts = rng.uniform(scene.bounds[0], scene.bounds[1], (2000, 2))
    want = potmap.Evaluator(ctx, m, tau=0.5).evaluate(pts).mean
    m.cutoff_tau = 0.5
    np.testing.assert_array_equal(potmap.Evaluator(ctx, m).evaluate(pts).mean, want)
    path = tmp_path / "cut.potmap"
    m.save(str(path))
    assert potmap.read_map(str(path)).cutoff_tau == 0.5


def test_evaluate_matches_the_exact_sum(scene, ctx, rng):
    pts = rng.uniform(scene.bounds[0], scene.bounds[1], (3000, 2))
    dev = scene.map.evaluate(pts, ctx)
    exact = scene.map.evaluate_exact(pts)
    assert dev.prob.dtype == np.float32 and exact.prob.dtype == np.float64
    assert np.max(np.abs(dev.prob - exact.prob)) < 1e-6
    assert np.max(np.abs(dev.mean - exact.mean) / (1 + np.abs(exact.mean))) < 1e-4
    assert np.max(np.abs(dev.var - exact.var) / (1 + exact.var)) < 1e-5
    p, mean, var = dev  # unpacks as (prob, mean, var)
    assert p is dev.prob and mean is dev.mean and var is dev.var


def test_float32_and_strided_points_give_the_same_values(scene, ctx, rng):
    ev = potmap.Evaluator(ctx, scene.map)
    pts = rng.uniform(0, 20, (500, 2)).astype(np.float32).astype(np.float64)
    ref = ev.evaluate(pts).prob
    np.testing.assert_array_equal(ev.evaluate(pts.astype(np.float32)).prob, ref)
    wide = np.zeros((500, 4))
    wide[:, ::2] = pts
    np.testing.assert_array_equal(ev.evaluate(wide[:, ::2]).prob, ref)  # a strided view
    np.testing.assert_array_equal(ev.evaluate(np.asfortranarray(pts)).prob, ref)
    assert ev.evaluate(np.zeros((0, 2))).prob.shape == (0,)


def test_eval_scores_equal_the_potmap_command(scene, ctx, cli, tmp_path):
    map_path, test_path = tmp_path / "scene.potmap", tmp_path / "test.csv"
    scene.map.save(str(map_path))
    write_test_csv(scene.test, test_path)
    prob = scene.map.evaluate(scene.test.positions, ctx).prob
    s = potmap.score(prob, scene.test.labels)
    c = cli("eval", "--map", map_path, "--test", test_path, "--json", "-", json_out=True)
    assert s.n == len(scene.test)
    assert abs(s.acc - c["acc"]) < 1e-12
    assert abs(s.auc - c["auc"]) < 1e-12
    assert abs(s.nll - c["nll"]) < 1e-9
    exact = potmap.score(scene.map.evaluate_exact(scene.test.positions).prob, scene.test.labels)
    r = cli("eval", "--map", map_path, "--test", test_path, "--reference", "--json", "-", json_out=True)
    assert abs(exact.auc - r["auc"]) < 1e-12 and abs(exact.nll - r["nll"]) < 1e-12


def test_raster_equals_the_potmap_command(scene, ctx, cli, tmp_path):
    map_path = tmp_path / "scene.potmap"
    scene.map.save(str(map_path))
    xmin, xmax, ymin, ymax = scene.bounds
    bounds = (xmin, xmax, ymin, ymax - 3.3)  # not square: rows and columns cannot be confused
    cli("raster", "--map", map_path, "--bounds", ",".join(map(repr, bounds)), "--res", 0.25,
        "--out", tmp_path / "c", "--no-png")
    prob, mean, var = scene.map.raster(bounds, 0.25, ctx)
    c_prob = np.load(tmp_path / "c_prob.npy")
    c_var = np.load(tmp_path / "c_var.npy")
    assert prob.shape == c_prob.shape and prob.shape[0] < prob.shape[1]
    assert np.max(np.abs(prob - c_prob)) < 1e-6
    assert np.max(np.abs(var - c_var) / (1 + c_var)) < 1e-6
    # Row 0 is the top: the first row's centres sit half a cell under the window's top.
    res = 0.25
    top = np.column_stack([xmin + (np.arange(prob.shape[1]) + 0.5) * res,
                           np.full(prob.shape[1], ymin + (prob.shape[0] - 0.5) * res)])
    assert np.max(np.abs(scene.map.evaluate(top, ctx).prob - prob[0])) < 1e-6
    summary = potmap.rasterize(ctx, scene.map, bounds, 0.25, str(tmp_path / "p"), png=False)
    assert (summary["height"], summary["width"]) == prob.shape
    np.testing.assert_array_equal(np.load(tmp_path / "p_prob.npy"), c_prob)


def test_height_band_is_the_maximum_of_its_slices(rng, ctx, cli, tmp_path):
    pos = np.column_stack([rng.uniform(0, 6, 80), rng.uniform(0, 5, 80), rng.uniform(0, 2, 80)])
    m = potmap.KernelMap(pos, np.full(80, 3.0), rng.normal(size=80) * 3, np.full(80, 0.2))
    bounds = (0.0, 6.0, 0.0, 5.0)
    prob, mean, var = m.raster(bounds, 0.25, ctx, band=(0.0, 2.0), band_step=0.25)
    slices = [m.raster(bounds, 0.25, ctx, z=0.25 * k) for k in range(9)]
    best = np.max([s.prob for s in slices], axis=0)
    assert np.max(np.abs(prob - best)) < 1e-5
    at = np.argmax([s.prob for s in slices], axis=0)
    pick = np.take_along_axis(np.array([s.var for s in slices]), at[None], 0)[0]
    assert np.mean(np.abs(var - pick) < 1e-4 * (1 + pick)) > 0.99
    # The command and rasterize() write the same band.
    map_path = tmp_path / "m3.potmap"
    m.save(str(map_path))
    cli("raster", "--map", map_path, "--bounds", "0,6,0,5", "--res", 0.25, "--band", "0,2",
        "--band-step", 0.25, "--out", tmp_path / "c", "--no-png")
    s = potmap.rasterize(ctx, m, bounds, 0.25, str(tmp_path / "p"), png=False, band=(0.0, 2.0),
                         band_step=0.25)
    assert s["levels"] == 9
    np.testing.assert_array_equal(np.load(tmp_path / "p_prob.npy"), np.load(tmp_path / "c_prob.npy"))
    assert np.max(np.abs(np.load(tmp_path / "c_prob.npy") - prob)) < 1e-6


@pytest.mark.parametrize("ext", ["csv", "npz", "potmap"])
def test_every_format_round_trips(scene, tmp_path, ext):
    path = str(tmp_path / f"m.{ext}")
    src = scene.map
    m = potmap.KernelMap(src.positions, src.gamma, src.w_mean, src.w_var, bias=(0.25, 3.0))
    potmap.write_map(m, path)
    back = potmap.KernelMap.load(path)
    np.testing.assert_array_equal(back.positions, m.positions)
    np.testing.assert_array_equal(back.gamma, m.gamma)
    np.testing.assert_array_equal(back.w_mean, m.w_mean)
    np.testing.assert_array_equal(back.w_var, m.w_var)
    assert back.bias == (0.25, 3.0)


def test_reads_the_authors_map(data_dir, ctx):
    m = potmap.read_map(f"{data_dir}/carla/town1_abhm_map.csv")
    assert m.dim == 2 and len(m) == 92372
    pts = potmap.read_labelled_csv(f"{data_dir}/carla/town1_test2k.csv")
    s = potmap.score(m.evaluate(pts.positions, ctx).prob, pts.labels)
    assert abs(s.auc - 0.865) < 0.001 and abs(s.acc - 0.811) < 0.001  # docs/commands.md's figures


def test_metrics_on_known_values():
    s = potmap.score(np.array([0.9, 0.2, 0.6, 0.4]), np.array([1, 0, 0, 1], dtype=bool))
    assert s.acc == 0.5 and s.auc == 0.75 and s.n == 4
    assert abs(s.nll - np.mean(-np.log([0.9, 0.8, 0.4, 0.4]))) < 1e-12


def test_threads_sharing_one_evaluator_take_turns(scene, ctx, rng):
    import threading

    ev = potmap.Evaluator(ctx, scene.map)
    pts = [rng.uniform(0, 20, (5000, 2)) for _ in range(8)]
    serial = [ev.evaluate(p).prob for p in pts]
    out = [None] * len(pts)

    def work(i):
        for _ in range(5):
            out[i] = ev.evaluate(pts[i]).prob

    threads = [threading.Thread(target=work, args=(i,)) for i in range(len(pts))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for a, b in zip(out, serial):
        np.testing.assert_array_equal(a, b)


@pytest.mark.skipif(not potmap.geotiff_supported(), reason="built without GDAL")
def test_geotiff_job_equals_the_potmap_command_and_resumes(scene, ctx, cli, tmp_path):
    map_path = tmp_path / "scene.potmap"
    scene.map.save(str(map_path))
    xmin, xmax, ymin, ymax = scene.bounds
    bounds = (xmin, xmax, ymin, ymax - 3.3)
    cli("raster", "--map", map_path, "--bounds", ",".join(map(repr, bounds)), "--res", 0.05,
        "--tile", 64, "--compress-level", 5, "--out", tmp_path / "c.tif")
    out = str(tmp_path / "p.tif")
    s = potmap.rasterize_geotiff(ctx, scene.map, bounds, 0.05, out, tile=64, compress_level=5,
                                 keep_tiles=True)
    assert s["tiles"] > 4 and s["computed"] == s["tiles"] and s["reused"] == 0
    assert s["output"] == out
    assert (tmp_path / "p.tif").read_bytes() == (tmp_path / "c.tif").read_bytes()
    again = potmap.rasterize_geotiff(ctx, scene.map, bounds, 0.05, out, tile=64,
                                     compress_level=5)
    assert again["reused"] == again["tiles"] and again["computed"] == 0
    assert (tmp_path / "p.tif").read_bytes() == (tmp_path / "c.tif").read_bytes()
    assert not (tmp_path / "p.tif.tiles").exists()
    with pytest.raises(potmap.ArgumentError, match="level 5 for LZW"):
        potmap.rasterize_geotiff(ctx, scene.map, bounds, 0.05, str(tmp_path / "x.tif"),
                                 compress="lzw", compress_level=5)
