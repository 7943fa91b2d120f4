"""3D drives from Python: a drive indexed and read a keyframe at a time, mapped by the drive
mapper, the same map as the command's, scored on its held-out samples."""

import json
import os

import numpy as np
import pytest

import potmap

DATA = os.environ.get("POTMAP_DATA", os.path.join(os.path.dirname(__file__), "..", "..", "..",
                                                  "shared", "data"))
HKU = os.path.join(DATA, "drives3d", "hku-1")

pytestmark = pytest.mark.skipif(not os.path.isdir(HKU), reason="../shared/data not present")


def test_open_drive_indexes_the_livox_walk():
    d = potmap.open_drive(HKU)
    assert len(d) == 314 and d.layout == "slam"
    assert d.poses.shape == (314, 3, 4)
    k = d.keyframe(3)
    assert k.dim == 3
    assert np.allclose(k.pose[:, 3], d.poses[3][:, 3])
    with pytest.raises(potmap.InputError, match="not a drive folder"):
        potmap.open_drive(os.path.join(DATA, "radish"))


def test_map_drive_equals_the_command_and_beats_the_grid(ctx, cli, tmp_path):
    m = potmap.map_drive(HKU, count=4)
    assert m.keyframes == 4 and m.memory_bytes > 0
    kmap = m.map()
    assert kmap.dim == 3 and len(kmap) > 1000
    # The command maps the same keyframes with the same defaults: the same scores.
    out = cli("mapping", HKU, "--max-scans", 4, "-q", "-o", tmp_path / "cmd", "--json", "-",
              json_out=True)
    test = m.held_out
    p = kmap.evaluate(test.positions, ctx).prob
    s = potmap.score(p, test.labels)
    assert s.n == out["scores"]["n"]
    # The command evaluates a 64 m column at a time: the same kernels, summed in another order.
    assert abs(s.auc - out["scores"]["auc"]) < 1e-4
    assert abs(s.nll - out["scores"]["nll"]) < 1e-4
    assert s.auc > 0.975  # measured 0.982 (OctoMap 0.2 m on this drive: 0.96)


def test_the_map_so_far_is_exported_between_keyframes_as_the_command_writes_it(ctx, cli, tmp_path):
    d = potmap.open_drive(HKU)
    m = potmap.DriveMapper()
    path = []
    for i in range(6):
        m.add(d.keyframe(i), i, ctx)
        path += list(d.poses[i][:, 3])
        if i == 2:  # a planner's look at the map so far, between keyframes
            v = potmap.export_drive_volume(ctx, m.map(), path, octomap=str(tmp_path / "so_far.bt"))
            assert v["occupied"] > 1000 and v["free"] > v["occupied"]
            assert v["band_prob"].shape == (int(round(v["band_prob"].size / v["band_prob"].shape[1])),
                                            v["band_prob"].shape[1])
            assert (v["band_prob"] >= 0).sum() > 1000  # known band cells
    fractions = []
    v = potmap.export_drive_volume(ctx, m.map(), path, octomap=str(tmp_path / "map.bt"),
                                   cloud=str(tmp_path / "map.ply"), progress=fractions.append)
    assert fractions and fractions[-1] == 1.0
    cli("mapping", HKU, "--max-scans", 6, "-q", "-o", tmp_path / "cmd")
    for f, g in (("map.bt", "map.bt"), ("map.ply", "map_occupied.ply")):
        assert (tmp_path / f).read_bytes() == (tmp_path / "cmd" / g).read_bytes(), f
    # A progress callback that raises stops the export, and nothing is written.
    def stop(fraction):
        raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        potmap.export_drive_volume(ctx, m.map(), path, octomap=str(tmp_path / "stopped.bt"),
                                   progress=stop)
    assert not any(p.name.startswith("stopped") for p in tmp_path.iterdir())


def test_drive_mapper_keyframe_by_keyframe_with_a_saved_state(tmp_path):
    d = potmap.open_drive(HKU)
    a = potmap.DriveMapper(range_cut=20)
    for i in range(3):
        st = a.add(d.keyframe(i), i)
        assert st.gathered < st.samples
    a.save_state(str(tmp_path / "s.state"))
    b = potmap.DriveMapper(range_cut=20)
    b.load_state(str(tmp_path / "s.state"))
    a.add(d.keyframe(3), 3)
    b.add(d.keyframe(3), 3)
    assert np.array_equal(a.map().w_mean, b.map().w_mean)
    with pytest.raises(potmap.InputError, match="other drive mapper options"):
        potmap.DriveMapper(range_cut=30).load_state(str(tmp_path / "s.state"))


def test_the_look_ahead_equals_the_command(ctx, cli, tmp_path):
    d = potmap.open_drive(HKU)
    m = potmap.DriveMapper(lookahead=True)
    for i in range(4):
        m.add(d.keyframe(i), i, ctx)
    prob, label, beyond = m.lookahead
    assert prob.dtype == np.float32 and len(prob) == len(label) == len(beyond) > 1000
    out = cli("mapping", HKU, "--max-scans", 4, "--lookahead", "-q", "-o", tmp_path / "cmd",
              "--json", "-", json_out=True)
    s = potmap.score(prob, label)
    assert s.n == out["lookahead"]["all"]["n"]
    assert abs(s.nll - out["lookahead"]["all"]["nll"]) < 1e-12
    b = potmap.score(prob[beyond == 1], label[beyond == 1])
    assert b.n == out["lookahead"]["beyond_reach"]["n"]


def test_repot_drive_mapper_seeds_from_a_dictionary_of_the_drive(ctx):
    d = potmap.open_drive(HKU)
    src = potmap.DriveMapper(range_cut=20)
    scans = [potmap.experiment.limit_range(d.keyframe(i), 20) for i in range(3)]
    for i in range(3):
        src.add(d.keyframe(i), i, ctx)
    atoms = potmap.build_dictionary(scans, src.map(), kernels_at_samples=1.0,
                                    max_weight_variance=5.0, free_per_metre=0.5)
    m = potmap.DriveMapper(range_cut=20, dictionary=atoms, transfer_every=1)
    assert m is not None
    seeded = 0
    for i in range(10, 12):
        st = m.add(d.keyframe(i), i, ctx)
        assert st.transfer_ms > 0
        seeded += st.seeded
    assert seeded > 0
    flat = potmap.Dictionary()
    with pytest.raises(ValueError, match="3D atoms"):
        potmap.DriveMapper(dictionary=flat)



def test_the_learners_sums_run_where_the_options_say(ctx):
    # The PoCL device has doubles: 'device' runs the features and sums there, 'host' on the host,
    # the same keyframes give the same samples and kernels, and scores to rounding.
    d = potmap.open_drive(HKU)
    runs = {}
    for where in ("host", "device"):
        bhm = potmap.DriveMapperOptions().bhm
        bhm.sums = where
        m = potmap.DriveMapper(range_cut=20, bhm=bhm)
        for i in range(2):
            st = m.add(d.keyframe(i), i, ctx)
            assert st.sums_on_device == (where == "device")
        t = m.held_out
        runs[where] = (len(m.map()), potmap.score(m.map().evaluate(t.positions, ctx).prob, t.labels))
    assert runs["host"][0] == runs["device"][0] > 1000
    assert abs(runs["host"][1].auc - runs["device"][1].auc) < 1e-4
    assert abs(runs["host"][1].nll - runs["device"][1].nll) < 1e-4


def test_two_drive_mappers_saved_and_merged(tmp_path):
    # Each half of four keyframes in its own mapper, every tile kept so that the map files carry
    # the information form; merged, the map covers both halves' kernels.
    d = potmap.open_drive(HKU)
    halves = [potmap.DriveMapper(range_cut=20, retire_radius=0) for _ in range(2)]
    for i in range(4):
        halves[i // 2].add(d.keyframe(i), i)
    paths = [str(tmp_path / f"{n}.potmap") for n in "ab"]
    for m, p in zip(halves, paths):
        m.save_map(p)
    out = str(tmp_path / "both.potmap")
    potmap.merge_maps(paths, out)
    both = potmap.read_map(out)
    sizes = [len(m.map()) for m in halves]
    assert max(sizes) <= len(both) <= sum(sizes)
    with pytest.raises(potmap.ArgumentError, match="scan fingerprints"):
        potmap.merge_maps([paths[0], paths[0]], str(tmp_path / "aa.potmap"))
    potmap.write_map(halves[0].map(), str(tmp_path / "plain.potmap"))
    with pytest.raises(potmap.InputError, match="without its information form"):
        potmap.merge_maps([paths[0], str(tmp_path / "plain.potmap")], out)
