"""ROS bags from Python: a bag written by ROS's own tools (Debian's python3-rosbag, run as its
own interpreter) summarised and read with chosen options, the same scans as the log it came
from."""

import os
import subprocess

import numpy as np
import pytest

import potmap

DATA = os.environ.get("POTMAP_DATA", os.path.join(os.path.dirname(__file__), "..", "..", "..",
                                                  "shared", "data"))
INTEL = os.path.join(DATA, "radish", "intel-corrected.log.gz")
WRITER = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "data", "write_ros1_bag.py")
DEBIAN_PYTHON = "/usr/bin/python3"


def has_rosbag():
    return os.path.exists(DEBIAN_PYTHON) and subprocess.run(
        [DEBIAN_PYTHON, "-c", "import rosbag"], capture_output=True).returncode == 0


pytestmark = [pytest.mark.skipif(not os.path.exists(INTEL), reason="../shared/data not present"),
              pytest.mark.skipif(not has_rosbag(), reason="python3-rosbag not installed")]


def write_bag(tmp_path, *args):
    out = str(tmp_path / "run.bag")
    subprocess.run([DEBIAN_PYTHON, WRITER, *args, out], check=True)
    return out


def test_a_bag_reads_as_the_log_it_was_written_from(tmp_path):
    bag = write_bag(tmp_path, "carmen", INTEL, "--scans", "10")
    s = potmap.summarise_bag(bag)
    assert (s.format, s.topic, s.dim, s.pose_source) == ("ROS 1 bag", "/scan", 2, "/tf")
    assert [t.name for t in s.topics] == ["/odom", "/scan", "/tf", "/tf_static"]
    assert potmap.is_bag(bag)
    scans = potmap.read_bag(bag, potmap.BagOptions(pose_topic="/odom")).scans
    log = potmap.read_carmen(INTEL, scans[0].max_range).scans[:10]
    assert len(scans) == 10
    for a, b in zip(scans, log):
        assert np.allclose(a.pose[:3], b.pose[:3], atol=1e-6)
        assert np.allclose(a.hits, b.hits, atol=1e-4)
    assert len(potmap.read_dataset(bag, potmap.BagOptions(topic="/scan")).scans) == 10
    with pytest.raises(potmap.InputError, match="no topic /points"):
        potmap.read_bag(bag, potmap.BagOptions(topic="/points"))


def test_a_cloud_topic_opens_as_a_drive(tmp_path):
    bag = write_bag(tmp_path, "clouds", "--clouds", "6")
    d = potmap.open_drive(bag, bag=potmap.BagOptions(keyframe_distance=0, keyframe_angle=0))
    assert d.layout == "rosbag" and len(d) == 6
    assert d.keyframe(2).dim == 3
    assert np.allclose(d.poses[2][:, 3], [1.0, 0.0, 1.5])
