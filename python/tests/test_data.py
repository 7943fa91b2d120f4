"""Datasets, scans as arrays and labelling, against the readers' C++ results."""

import numpy as np

import potmap


def test_intel_log_as_the_command_reads_it(data_dir, cli):
    path = f"{data_dir}/radish/intel-corrected.log.gz"
    d = potmap.read_dataset(path)
    info = cli("data", "info", path)
    field = dict(line.split(": ", 1) for line in info.splitlines() if ": " in line)
    assert len(d) == int(field["scans"]) > 100
    assert sum(len(s.hits) for s in d.scans) == int(field["hits"])
    assert sum(len(s.no_return) for s in d.scans) == int(field["no-return beams"])
    assert d.stats.lines_skipped == int(field["lines skipped"])
    s = d[0]
    assert s.dim == 2 and s.hits.shape[1] == 2 and s.max_range > 0
    assert s.num_beams == len(s.hits) + len(s.no_return)
    assert len(s.pose) == 3
    # Hits lie within max_range of the sensor.
    r = np.linalg.norm(s.hits - np.array(s.origin), axis=1)
    assert np.all(r < s.max_range + 1e-9)


def test_label_equals_per_scan_labelling(town_scans):
    split = potmap.label(town_scans, free_per_metre=0.5, holdout=0.25, seed=3)
    train, test = split
    assert train.dim == 2 and len(train) > 0 and len(test) > 0
    assert set(np.unique(train.labels)) == {0, 1}
    # Scan i of the list is labelled with index i: label_scan reproduces it exactly.
    one = potmap.label_scan(town_scans[2], index=2, free_per_metre=0.5, holdout=0.25, seed=3)
    mask = train.scan == 2
    np.testing.assert_array_equal(train.positions[mask], one.train.positions)
    np.testing.assert_array_equal(train.labels[mask], one.train.labels)
    # Hits of the kept beams are the training samples with label 1.
    kept = potmap.split_beams(town_scans[2], index=2, holdout=0.25, seed=3)
    np.testing.assert_array_equal(np.sort(kept.hits, axis=0), np.sort(one.train.positions[one.train.labels == 1], axis=0))
    # Another seed, another split.
    other = potmap.label(town_scans, free_per_metre=0.5, holdout=0.25, seed=4).train
    assert len(other) != len(train) or not np.array_equal(other.positions, train.positions)


def test_labelled_csv_round_trip_equals_the_command_input(town_scans, tmp_path, cli):
    train = potmap.label(town_scans[:2]).train
    path = str(tmp_path / "train.csv")
    potmap.write_labelled_csv(train, path)
    back = potmap.read_labelled_csv(path)
    np.testing.assert_array_equal(back.positions, train.positions)
    np.testing.assert_array_equal(back.labels, train.labels)
    np.testing.assert_array_equal(back.scan, train.scan)
    d = potmap.read_dataset(path)  # as labelled samples grouped into scans
    assert len(d) == 2


def test_scan_from_arrays_and_simulated_dataset(tmp_path, cli):
    s = potmap.Scan(np.array([[1.0, 0.0], [0.0, 2.0]]), no_return=np.array([[-1.0, 0.0]]),
                    pose=(0.0, 0.0, 0.5), max_range=10.0)
    assert s.num_beams == 3 and s.pose == (0.0, 0.0, 0.5)
    split = potmap.label([s], holdout=0.0)
    assert (split.train.labels == 1).sum() == 2 and split.test.positions.shape == (0, 2)
    # The command's simulator and the binding's give the same scans.
    cli("data", "simulate", "--town", "town2", "--scans", 3, "--seed", 5, "--out", tmp_path / "sim")
    mine = potmap.simulate(potmap.Town.builtin("town2", seed=5), scans=3, seed=5)
    theirs = potmap.read_dataset(str(tmp_path / "sim" / "scans.log"))
    assert len(theirs) == 3
    for a, b in zip(mine.scans, theirs.scans):
        # The log keeps millimetres (a hit at the range limit may read back as a no-return).
        assert a.num_beams == b.num_beams
        np.testing.assert_allclose(a.pose, b.pose, atol=1e-3)
    # ... and label them as the command did (train.csv: the default split, seed 5).
    train = potmap.label(mine.scans, seed=5).train
    written = potmap.read_labelled_csv(str(tmp_path / "sim" / "train.csv"))
    np.testing.assert_array_equal(written.positions, train.positions)
    np.testing.assert_array_equal(written.labels, train.labels)


def test_3d_frames_and_slices(data_dir, cli):
    kitti = potmap.read_kitti_bin(f"{data_dir}/lidar3d/kitti_000008.bin")
    nusc = potmap.read_nuscenes_bin(f"{data_dir}/lidar3d/nuscenes_lidar_top_1532402927647951.bin")
    for path, scan in ((f"{data_dir}/lidar3d/kitti_000008.bin", kitti),
                       (f"{data_dir}/lidar3d/nuscenes_lidar_top_1532402927647951.bin", nusc)):
        info = cli("data", "info", path)
        field = dict(line.split(": ", 1) for line in info.splitlines() if ": " in line)
        assert scan.dim == 3 and scan.hits.shape == (int(field["hits"]), 3)
        assert scan.pose.shape == (3, 4)
    raw = np.fromfile(f"{data_dir}/lidar3d/kitti_000008.bin", dtype=np.float32).reshape(-1, 4)
    keep = np.all(np.isfinite(raw[:, :3]), axis=1)
    np.testing.assert_allclose(kitti.hits, raw[keep, :3].astype(np.float64)[: len(kitti.hits)])
    flat = potmap.slice_2d(kitti, -0.2, 0.2)
    assert flat.dim == 2 and 0 < len(flat.hits) < len(kitti.hits)


def test_npz_labelled_samples(tmp_path):
    x = np.column_stack([np.repeat([0, 1], 5), np.arange(10.0), np.arange(10.0) * 2])
    y = np.array([0, 1] * 5)
    np.savez(tmp_path / "s.npz", X=x, Y=y)
    pts = potmap.read_npz_labelled(str(tmp_path / "s.npz"))
    np.testing.assert_array_equal(pts.positions, x[:, 1:])
    np.testing.assert_array_equal(pts.labels, y)
    np.testing.assert_array_equal(pts.scan, x[:, 0].astype(np.int64))
    assert len(potmap.scans_from_labelled(pts)) == 2
