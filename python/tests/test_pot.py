"""POT and RePOT: dictionaries and the Mapper against `potmap dict build` and `potmap map`."""

import math

import numpy as np
import pytest

import potmap


@pytest.fixture(scope="module")
def source(cli, tmp_path_factory):
    """town1 simulated by the command, its joint BHM and dictionary, as the README builds them."""
    d = tmp_path_factory.mktemp("pot")
    cli("data", "simulate", "--town", "town1", "--scans", 6, "--spacing", 3, "--out", d / "src")
    cli("learn", "bhm", d / "src" / "train.csv", "-o", d / "src.potmap", "--sequential", "--no-bias")
    cli("dict", "build", "--scans", d / "src" / "scans.log", "--map", d / "src.potmap", "--out",
        d / "town1.potdict", "--kernels-at-samples", 0.5, "--max-weight-var", 5)
    cli("data", "simulate", "--town", "town2", "--scans", 3, "--spacing", 3, "--out", d / "dst")
    return d


def test_dictionary_equals_the_command(source, tmp_path):
    scans = potmap.read_dataset(str(source / "src" / "scans.log"))
    src_map = potmap.read_map(str(source / "src.potmap"))
    mine = potmap.build_dictionary(scans, src_map, kernels_at_samples=0.5, max_weight_variance=5.0)
    theirs = potmap.Dictionary.load(str(source / "town1.potdict"))
    assert len(mine) == len(theirs) > 0 and mine.dim == theirs.dim == 2
    assert mine.max_range == theirs.max_range and mine.scale == theirs.scale
    for a, b in zip(mine.atoms, theirs.atoms):
        assert a.sector.index == b.sector.index and a.scan_index == b.scan_index
        np.testing.assert_array_equal(a.sector.hits, b.sector.hits)
        np.testing.assert_array_equal(a.kernels.positions, b.kernels.positions)
        np.testing.assert_array_equal(a.kernels.w_mean, b.kernels.w_mean)
    path = str(tmp_path / "again.potdict")
    mine.save(path)
    back = potmap.read_dictionary(path)
    assert len(back) == len(mine)
    np.testing.assert_array_equal(back.atoms[-1].kernels.w_var, mine.atoms[-1].kernels.w_var)


def mapper_options():
    o = potmap.MapperOptions()
    o.pot.rotations = [2 * math.pi * i / 8 for i in range(8)]  # as `potmap map --rotations 8`
    return o


@pytest.mark.parametrize("refine", [False, True])
def test_mapper_equals_potmap_map(source, cli, ctx, tmp_path, refine):
    out = tmp_path / "overall.potmap"
    cli("map", "--dict", source / "town1.potdict", "--scans", source / "dst" / "scans.log",
        "-o", out, "-q", *(["--refine"] if refine else []))
    theirs = potmap.read_map(str(out))
    d = potmap.Dictionary.load(str(source / "town1.potdict"))
    # `potmap map`'s defaults are the library's (the indexed ranking, kernels on the scans'
    # samples for POT, RePOT's seeds barycentric, the averaged overall map, a wall clearance of
    # 0.5 m), but for its seeds' displacement variance (--displacement-var, 0).
    o = mapper_options()
    o.seed_displacement_variance = 0
    mapper = potmap.Mapper(ctx, d, refine=refine, options=o)
    del d  # the mapper keeps the dictionary
    stats = [mapper.add_scan(s) for s in potmap.read_dataset(str(source / "dst" / "scans.log"))]
    assert mapper.scans == 3 and [s.index for s in stats] == [0, 1, 2]
    for s in stats:
        assert len(s.sectors) > 0 and all(t.atom >= 0 for t in s.sectors)
        assert s.timing.total_ms > 0 and len(s.test) > 0
        assert (s.seeded > 0) == refine or not refine
    mine = mapper.overall_map()
    assert len(mine) == len(theirs) > 0
    np.testing.assert_allclose(mine.positions, theirs.positions, atol=1e-9)
    np.testing.assert_allclose(mine.w_mean, theirs.w_mean, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(mine.w_var, theirs.w_var, rtol=1e-6, atol=1e-9)
    assert (mine.bias is not None) == refine  # RePOT's persistent BHM has a bias
    # The overall map predicts the held-out beams far better than chance.
    test = stats[-1].test
    s = potmap.score(mine.evaluate(test.positions, ctx).prob, test.labels)
    assert s.auc > 0.8
    mapper.reset()
    assert mapper.scans == 0


def test_transfer_scan_matches_the_mapper_instantaneous_map(source, ctx):
    d = potmap.Dictionary.load(str(source / "town1.potdict"))
    scan = potmap.read_dataset(str(source / "dst" / "scans.log"))[0]
    mapper = potmap.Mapper(ctx, d, refine=True, options=mapper_options())
    first = mapper.add_scan(scan)
    assert len(first.train) > 0  # RePOT's persistent map hands back the training samples
    # RePOT's persistent map transfers with its seeds' placement and displacement variance.
    o = mapper_options()
    po = o.pot
    po.placement, po.displacement_variance = o.seed_placement, o.seed_displacement_variance
    t = potmap.transfer_scan(ctx, d, first.train, scan.origin, scan.pose[2], 0, options=po)
    assert len(t.map) == len(first.map) > 0
    np.testing.assert_allclose(t.map.positions, first.map.positions, atol=1e-9)
    np.testing.assert_allclose(t.map.w_mean, first.map.w_mean, atol=1e-9)


def test_host_helper_changes_no_map(source):
    """A context's host helper (the sectors' host work beside the scan's thread) maps as one
    thread does, bit for bit, with the settings that use it (indexed ranking, kernels on the
    scan's samples)."""
    d = potmap.Dictionary.load(str(source / "town1.potdict"))
    scans = list(potmap.read_dataset(str(source / "dst" / "scans.log")))
    o = mapper_options()
    o.pot.ranking = "indexed"
    o.pot.placement = "target_samples"
    o.pot.wall_clearance = 0.5
    o.average_overall = True
    maps = []
    for helper in (True, False):
        mapper = potmap.Mapper(potmap.Context(disk_cache=False, host_helper=helper), d, options=o)
        for s in scans:
            mapper.add_scan(s)
        maps.append(mapper.overall_map())
    assert len(maps[0]) == len(maps[1]) > 0
    for field in ("positions", "gamma", "w_mean", "w_var"):
        np.testing.assert_array_equal(getattr(maps[0], field), getattr(maps[1], field))


@pytest.mark.parametrize("refine", [False, True])
def test_async_merge_gives_the_same_map(source, ctx, refine):
    d = potmap.Dictionary.load(str(source / "town1.potdict"))
    scans = list(potmap.read_dataset(str(source / "dst" / "scans.log")))
    behind = mapper_options()
    behind.async_merge = True
    sync = potmap.Mapper(ctx, d, refine=refine, options=mapper_options())
    async_ = potmap.Mapper(ctx, d, refine=refine, options=behind)
    for s in scans:
        assert sync.add_scan(s).merge_ms > 0 or refine
        r = async_.add_scan(s)
        assert r.merge_ms == 0 and r.seeded == 0  # not merged yet: its counts are not known
    a, b = sync.overall_map(), async_.overall_map()  # the second waits for the last merge
    assert len(a) == len(b) > 0
    np.testing.assert_array_equal(a.w_mean, b.w_mean)
    np.testing.assert_array_equal(a.w_var, b.w_var)


@pytest.mark.parametrize("refine", [False, True])
def test_mapper_state_continues_bit_for_bit(source, ctx, tmp_path, refine):
    d = potmap.Dictionary.load(str(source / "town1.potdict"))
    scans = list(potmap.read_dataset(str(source / "dst" / "scans.log")))
    whole = potmap.Mapper(ctx, d, refine=refine, options=mapper_options())
    for s in scans:
        whole.add_scan(s)
    first = potmap.Mapper(ctx, d, refine=refine, options=mapper_options())
    first.add_scan(scans[0])
    path = str(tmp_path / "mapper.state")
    first.save_state(path)
    resumed = potmap.Mapper(ctx, d, refine=refine, options=mapper_options())
    resumed.load_state(path)
    assert resumed.scans == 1
    assert [resumed.add_scan(s).index for s in scans[1:]] == [1, 2]
    a, b = whole.overall_map(), resumed.overall_map()
    assert len(a) == len(b) > 0
    np.testing.assert_array_equal(a.positions, b.positions)  # exactly, not close
    np.testing.assert_array_equal(a.w_mean, b.w_mean)
    np.testing.assert_array_equal(a.w_var, b.w_var)
    other = mapper_options()
    other.pot.seed = 9
    with pytest.raises(potmap.InputError, match="options"):
        potmap.Mapper(ctx, d, refine=refine, options=other).load_state(path)
    (tmp_path / "half.state").write_bytes(open(path, "rb").read()[:100])
    with pytest.raises(potmap.InputError, match="half.state"):
        resumed.load_state(str(tmp_path / "half.state"))
    assert resumed.scans == 3
