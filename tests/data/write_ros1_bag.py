#!/usr/bin/env python3
"""Writes ROS 1 bags with ROS's own Python tools (Debian's python3-rosbag and message modules),
for tests that compare potmap's bag reader with the same data read another way.

  write_ros1_bag.py carmen LOG OUT.bag [--scans N] [--compression none|bz2|lz4]
      The first N FLASER scans of a CARMEN log (plain or .gz) as sensor_msgs/LaserScan on /scan
      (frame "laser"), the robot's pose as /tf odom -> base_link at each scan's stamp, the laser
      0.25 m ahead of base_link on /tf_static, and the same poses as nav_msgs/Odometry on /odom.
  write_ros1_bag.py clouds OUT.bag [--clouds N] [--compression ...]
      N synthetic sweeps as sensor_msgs/PointCloud2 on /points (frame "os_sensor", x y z
      intensity float32, every 7th point NaN), base_link moving 0.5 m and turning 0.05 rad per
      sweep on /tf (odom -> base_link, stamps 0.1 s apart, written a little after each sweep),
      the sensor 1.5 m above base_link on /tf_static.
  write_ros1_bag.py drive FOLDER OUT.bag [--keyframes N]
      The first N keyframes of a SLAM keyframe folder (Scans/NNNNNN.pcd, binary float32 fields,
      odom_poses.txt, times.txt) as sensor_msgs/PointCloud2 on /points (frame "os_sensor") with
      their poses on /tf (odom -> os_sensor) at the keyframes' times.
"""
import argparse
import gzip
import math
import os
import struct

import rosbag
import rospy
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserEcho, LaserScan, MultiEchoLaserScan, PointCloud2, PointField
from tf2_msgs.msg import TFMessage

LASER_AHEAD = 0.25  # metres, base_link -> laser
SENSOR_UP = 1.5  # metres, base_link -> os_sensor


def quaternion_z(yaw):
    return 0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)


def transform(stamp, parent, child, x, y, z, yaw):
    t = TransformStamped()
    t.header.stamp = stamp
    t.header.frame_id = parent
    t.child_frame_id = child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = x, y, z
    q = quaternion_z(yaw)
    (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
     t.transform.rotation.w) = q
    return t


def flaser_lines(path, limit):
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rt") as f:
        for line in f:
            tok = line.split()
            if not tok or tok[0] != "FLASER":
                continue
            n = int(tok[1])
            ranges = [float(v) for v in tok[2:2 + n]]
            x, y, theta = (float(v) for v in tok[2 + n:5 + n])
            stamp = float(tok[8 + n])
            yield ranges, x, y, theta, stamp
            limit -= 1
            if limit == 0:
                return


def float32(v):
    return struct.unpack("<f", struct.pack("<f", v))[0]


def write_carmen_copy(path, scans):
    with open(path, "w") as f:
        for ranges, x, y, theta, stamp in scans:
            body = " ".join("%.9g" % float32(r) for r in ranges)
            f.write("FLASER %d %s %r %r %r %r %r %r %r h %r\n"
                    % (len(ranges), body, x, y, theta, x, y, theta, stamp, stamp))


def write_carmen(args, bag):
    scans = list(flaser_lines(args.log, args.scans))
    if args.carmen_copy:
        write_carmen_copy(args.carmen_copy, scans)
    # FLASER names no maximum range: readings at the device's limit are the log's largest.
    largest = max(max(r for r in ranges if math.isfinite(r)) for ranges, *_ in scans)
    bag.write("/tf_static", TFMessage([transform(rospy.Time.from_sec(scans[0][4]), "base_link",
                                                 "laser", LASER_AHEAD, 0, 0, 0)]),
              rospy.Time.from_sec(scans[0][4]))
    for ranges, x, y, theta, stamp in scans:
        t = rospy.Time.from_sec(stamp)
        n = len(ranges)
        fov = math.pi
        msg = LaserScan()
        msg.header.stamp, msg.header.frame_id = t, "laser"
        msg.angle_min = -fov / 2
        msg.angle_increment = fov / n if n % 2 == 0 else fov / (n - 1)
        msg.angle_max = msg.angle_min + msg.angle_increment * (n - 1)
        msg.range_min, msg.range_max = 0.0, largest * 0.999
        msg.ranges = ranges
        if args.multi_echo:
            # Each beam's first echo is the log's range; a farther second one follows it.
            echo = MultiEchoLaserScan()
            for name in ("header", "angle_min", "angle_max", "angle_increment", "range_min",
                         "range_max"):
                setattr(echo, name, getattr(msg, name))
            echo.ranges = [LaserEcho([r, r + 1.0]) for r in ranges]
            msg = echo
        # CARMEN's pose is the laser's; base_link sits LASER_AHEAD behind it.
        bx, by = x - LASER_AHEAD * math.cos(theta), y - LASER_AHEAD * math.sin(theta)
        bag.write("/tf", TFMessage([transform(t, "odom", "base_link", bx, by, 0, theta)]), t)
        odom = Odometry()
        odom.header.stamp, odom.header.frame_id, odom.child_frame_id = t, "odom", "base_link"
        odom.pose.pose.position.x, odom.pose.pose.position.y = bx, by
        q = quaternion_z(theta)
        (odom.pose.pose.orientation.x, odom.pose.pose.orientation.y,
         odom.pose.pose.orientation.z, odom.pose.pose.orientation.w) = q
        bag.write("/odom", odom, t)
        bag.write("/scan", msg, t)


def cloud_points(i):
    """Sweep i's points in the sensor frame: a ring of 360 at 10 m and a wall 5 m ahead."""
    pts = []
    for k in range(360):
        a = math.radians(k)
        pts.append((10 * math.cos(a), 10 * math.sin(a), -1.0 + 0.01 * (k % 50)))
    for k in range(100):
        pts.append((5.0, -2.5 + 0.05 * k, 0.1 * i))
    return pts


def write_clouds(args, bag):
    t0 = 1000.0
    bag.write("/tf_static", TFMessage([transform(rospy.Time.from_sec(t0), "base_link",
                                                 "os_sensor", 0, 0, SENSOR_UP, 0)]),
              rospy.Time.from_sec(t0))
    for i in range(args.clouds):
        t = rospy.Time.from_sec(t0 + 0.1 * i)
        bag.write("/tf", TFMessage([transform(t, "odom", "base_link", 0.5 * i, 0, 0, 0.05 * i)]), t)
        msg = PointCloud2()
        msg.header.stamp, msg.header.frame_id = t, "os_sensor"
        msg.fields = [PointField(name, 4 * k, PointField.FLOAT32, 1)
                      for k, name in enumerate(("x", "y", "z", "intensity"))]
        msg.point_step = 16
        pts = cloud_points(i)
        data = bytearray()
        for k, (x, y, z) in enumerate(pts):
            if k % 7 == 3:
                x = float("nan")
            data += struct.pack("<ffff", x, y, z, float(k))
        msg.height, msg.width = 1, len(pts)
        msg.row_step = msg.point_step * msg.width
        msg.is_bigendian, msg.is_dense = False, False
        msg.data = bytes(data)
        # Drivers publish a sweep when it ends; the bag receives it a moment later.
        bag.write("/points", msg, rospy.Time.from_sec(t0 + 0.1 * i + 0.02))
    last = rospy.Time.from_sec(t0 + 0.1 * args.clouds)
    bag.write("/tf", TFMessage([transform(last, "odom", "base_link", 0.5 * args.clouds, 0, 0,
                                          0.05 * args.clouds)]), last)


def read_binary_pcd(path):
    """x, y, z of a binary PCD of 4-byte float fields, as SLAM tools save keyframes."""
    with open(path, "rb") as f:
        head = {}
        while True:
            line = f.readline().decode().strip()
            if line.startswith("#") or not line:
                continue
            key, *vals = line.split()
            head[key] = vals
            if key == "DATA":
                break
        assert head["DATA"] == ["binary"] and set(head["SIZE"]) == {"4"} and set(head["TYPE"]) == {"F"}
        fields, n = head["FIELDS"], int(head["POINTS"][0])
        body = f.read(4 * len(fields) * n)
    rows = struct.iter_unpack("<%df" % len(fields), body)
    ix, iy, iz = fields.index("x"), fields.index("y"), fields.index("z")
    return [(r[ix], r[iy], r[iz]) for r in rows]


def quaternion(m):
    """A rotation matrix's unit quaternion (x, y, z, w), by the largest diagonal term."""
    t = m[0][0] + m[1][1] + m[2][2]
    if t > 0:
        s = 2 * math.sqrt(1 + t)
        return ((m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, s / 4)
    i = max(range(3), key=lambda k: m[k][k])
    j, k = (i + 1) % 3, (i + 2) % 3
    s = 2 * math.sqrt(1 + m[i][i] - m[j][j] - m[k][k])
    q = [0.0, 0.0, 0.0, (m[k][j] - m[j][k]) / s]
    q[i] = s / 4
    q[j] = (m[j][i] + m[i][j]) / s
    q[k] = (m[k][i] + m[i][k]) / s
    return tuple(q)


def write_drive(args, bag):
    folder = args.folder
    with open(os.path.join(folder, "odom_poses.txt")) as f:
        poses = [[float(v) for v in line.split()] for line in f if line.strip()]
    with open(os.path.join(folder, "times.txt")) as f:
        times = [float(line) for line in f if line.strip()]
    n = args.keyframes or len(poses)
    for i in range(n):
        t = rospy.Time.from_sec(times[i])
        p = poses[i]
        m = [p[0:3], p[4:7], p[8:11]]
        tf = TransformStamped()
        tf.header.stamp, tf.header.frame_id, tf.child_frame_id = t, "odom", "os_sensor"
        (tf.transform.translation.x, tf.transform.translation.y,
         tf.transform.translation.z) = p[3], p[7], p[11]
        (tf.transform.rotation.x, tf.transform.rotation.y, tf.transform.rotation.z,
         tf.transform.rotation.w) = quaternion(m)
        bag.write("/tf", TFMessage([tf]), t)
        pts = read_binary_pcd(os.path.join(folder, "Scans", "%06d.pcd" % i))
        msg = PointCloud2()
        msg.header.stamp, msg.header.frame_id = t, "os_sensor"
        msg.fields = [PointField(name, 4 * k, PointField.FLOAT32, 1)
                      for k, name in enumerate(("x", "y", "z"))]
        msg.point_step, msg.height, msg.width = 12, 1, len(pts)
        msg.row_step = 12 * len(pts)
        msg.is_bigendian, msg.is_dense = False, True
        msg.data = b"".join(struct.pack("<fff", *q) for q in pts)
        bag.write("/points", msg, t)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("kind", choices=("carmen", "clouds", "drive"))
    p.add_argument("paths", nargs="+",
                   help="carmen: LOG OUT.bag; clouds: OUT.bag; drive: FOLDER OUT.bag")
    p.add_argument("--keyframes", type=int, default=0, help="drive: first N keyframes (0: all)")
    p.add_argument("--scans", type=int, default=0, help="carmen: first N scans (0: all)")
    p.add_argument("--clouds", type=int, default=6)
    p.add_argument("--compression", default="none", choices=("none", "bz2", "lz4"))
    p.add_argument("--carmen-copy", default="", help="carmen: also write the scans as this log")
    p.add_argument("--multi-echo", action="store_true",
                   help="carmen: sensor_msgs/MultiEchoLaserScan, two echoes a beam")
    args = p.parse_intermixed_args()
    if args.kind == "carmen":
        args.log, out = args.paths
    elif args.kind == "drive":
        args.folder, out = args.paths
    else:
        (out,) = args.paths
    with rosbag.Bag(out, "w", compression=args.compression) as bag:
        {"carmen": write_carmen, "clouds": write_clouds, "drive": write_drive}[args.kind](args, bag)


if __name__ == "__main__":
    main()
