#!/usr/bin/env python3
"""Writes ROS 2 bags in rosbag2's sqlite3 layout for tests/ros2_bag_test.cpp, independently of
potmap's reader: the tables rosbag2_storage_default_plugins creates, a metadata.yaml of version 5,
and message bodies from a CDR encoder of its own (struct.pack, alignment counted from the end of
the 4-byte encapsulation header). Beside the bag, expected.json says what a reader must find.

usage: write_ros2_bag.py OUT_DIR SCENARIO
scenarios: scan_tf, cloud, misc, zstd_file, zstd_message, truncated, mcap, corrupt, no_tables
"""
import json
import gzip
import math
import os
import sqlite3
import struct
import subprocess
import sys

NAN = float("nan")


def f32(x):
    """x as the float32 the bag stores, for exact comparisons."""
    return struct.unpack("<f", struct.pack("<f", x))[0]


class Cdr:
    def __init__(self, big_endian=False):
        self.order = ">" if big_endian else "<"
        # Representation identifier CDR_BE (0x0000) or CDR_LE (0x0001), then two option bytes.
        self.buf = bytearray(b"\x00\x00\x00\x00" if big_endian else b"\x00\x01\x00\x00")

    def align(self, n):
        self.buf += b"\x00" * ((-(len(self.buf) - 4)) % n)

    def prim(self, fmt, value):
        size = struct.calcsize(fmt)
        self.align(size)
        self.buf += struct.pack(self.order + fmt, value)

    def u8(self, v): self.prim("B", v)
    def u32(self, v): self.prim("I", v)
    def i32(self, v): self.prim("i", v)
    def f32(self, v): self.prim("f", v)
    def f64(self, v): self.prim("d", v)

    def string(self, s):
        b = s.encode() + b"\x00"
        self.u32(len(b))
        self.buf += b

    def header(self, sec, nanosec, frame):
        self.i32(sec)
        self.u32(nanosec)
        self.string(frame)

    def f32_seq(self, values):
        self.u32(len(values))
        for v in values:
            self.f32(v)

    def pose(self, t, q):
        for v in list(t) + list(q):
            self.f64(v)

    def bytes(self):
        return bytes(self.buf)


def stamp(sec, nanosec):
    return sec + nanosec * 1e-9


# --- messages: each returns (CDR bytes, what a reader must decode from it) ----------------------

def laser_scan(sec, nsec, frame, ranges, big_endian=False, amin=-1.5, ainc=0.25, rmin=0.1,
               rmax=30.0):
    c = Cdr(big_endian)
    c.header(sec, nsec, frame)
    for v in (amin, amin + ainc * (len(ranges) - 1), ainc, 0.001, 0.1, rmin, rmax):
        c.f32(v)
    c.f32_seq(ranges)
    c.f32_seq([100.0] * len(ranges))  # intensities
    exp = {"stamp": stamp(sec, nsec), "frame": frame, "angle_min": f32(amin),
           "angle_increment": f32(ainc), "range_min": f32(rmin), "range_max": f32(rmax),
           "ranges": [None if math.isnan(r) else f32(r) for r in ranges]}
    return c.bytes(), exp


def multi_echo(sec, nsec, frame, echoes):
    c = Cdr()
    c.header(sec, nsec, frame)
    for v in (-1.0, 1.0, 0.5, 0.0, 0.1, 0.2, 20.0):
        c.f32(v)
    c.u32(len(echoes))
    for e in echoes:
        c.f32_seq(e)
    c.u32(len(echoes))
    for e in echoes:
        c.f32_seq([1.0] * len(e))
    exp = {"stamp": stamp(sec, nsec), "frame": frame, "angle_min": -1.0, "angle_increment": 0.5,
           "range_min": f32(0.2), "range_max": 20.0,
           "ranges": [f32(e[0]) if e else None for e in echoes]}
    return c.bytes(), exp


def transform_stamped(c, sec, nsec, parent, child, t, q):
    c.header(sec, nsec, parent)
    c.string(child)
    c.pose(t, q)
    return {"stamp": stamp(sec, nsec), "parent": parent, "child": child, "t": list(t),
            "q": list(q)}


def tf_message(entries, static):
    c = Cdr()
    c.u32(len(entries))
    exps = []
    for e in entries:
        exp = transform_stamped(c, *e)
        exp["static"] = static
        exps.append(exp)
    return c.bytes(), exps


def odometry(sec, nsec, parent, child, t, q):
    c = Cdr()
    exp = transform_stamped(c, sec, nsec, parent, child, t, q)
    for i in range(36):
        c.f64(float(i))  # pose covariance
    for v in range(6):
        c.f64(0.5)  # twist
    for i in range(36):
        c.f64(0.0)
    exp["static"] = False
    return c.bytes(), exp


def pose_stamped(sec, nsec, frame, t, q):
    c = Cdr()
    c.header(sec, nsec, frame)
    c.pose(t, q)
    return c.bytes(), {"stamp": stamp(sec, nsec), "parent": frame, "child": "", "t": list(t),
                       "q": list(q), "static": False}


def point_cloud2(sec, nsec, frame, points, double, big_endian):
    """points: (x, y, z); double: FLOAT64 fields with an intensity between y and z."""
    c = Cdr(big_endian)
    c.header(sec, nsec, frame)
    order = ">" if big_endian else "<"
    if double:
        fields = [("x", 0, 8), ("y", 8, 8), ("intensity", 16, 7), ("z", 20, 8)]
        step = 32
    else:
        fields = [("x", 0, 7), ("y", 4, 7), ("z", 8, 7), ("intensity", 12, 7)]
        step = 16
    data = bytearray()
    for p in points:
        rec = bytearray(step)
        vals = {"x": p[0], "y": p[1], "z": p[2], "intensity": 7.0}
        for name, off, dt in fields:
            struct.pack_into(order + ("d" if dt == 8 else "f"), rec, off, vals[name])
        data += rec
    c.u32(1)  # height
    c.u32(len(points))  # width
    c.u32(len(fields))
    for name, off, dt in fields:
        c.string(name)
        c.u32(off)
        c.u8(dt)
        c.u32(1)
    c.u8(1 if big_endian else 0)
    c.u32(step)
    c.u32(step * len(points))
    c.u32(len(data))
    c.buf += data
    c.u8(0)  # is_dense
    xyz, dropped = [], 0
    for p in points:
        if any(math.isnan(v) for v in p) or p == (0.0, 0.0, 0.0):
            dropped += 1
        else:
            xyz += [f32(v) for v in p]
    return c.bytes(), {"stamp": stamp(sec, nsec), "frame": frame, "xyz": xyz,
                       "dropped": dropped}


# --- storage -----------------------------------------------------------------------------------

QOS = ("- history: 3\n  depth: 0\n  reliability: 1\n  durability: 2\n  deadline:\n    sec: "
       "2147483647\n    nsec: 4294967295\n  lifespan:\n    sec: 2147483647\n    nsec: 4294967295\n"
       "  liveliness: 1\n  liveliness_lease_duration:\n    sec: 2147483647\n    nsec: "
       "4294967295\n  avoid_ros_namespace_conventions: false")


def write_db3(path, topic_order, messages, types):
    """messages: (topic, receive ns, bytes), in the order a recorder writes them."""
    db = sqlite3.connect(path)
    db.executescript(
        "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);"
        "CREATE TABLE metadata(id INTEGER PRIMARY KEY, metadata_version INTEGER NOT NULL, "
        "metadata TEXT NOT NULL);"
        "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, "
        "serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);"
        "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, "
        "timestamp INTEGER NOT NULL, data BLOB NOT NULL);"
        "CREATE INDEX timestamp_idx ON messages (timestamp ASC);")
    db.execute("INSERT INTO schema VALUES (3, 'humble')")
    ids = {}
    for name in topic_order:
        cur = db.execute("INSERT INTO topics (name, type, serialization_format, "
                         "offered_qos_profiles) VALUES (?, ?, 'cdr', ?)",
                         (name, types[name], QOS))
        ids[name] = cur.lastrowid
    keys = []
    for topic, ns, data in messages:
        cur = db.execute("INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)",
                         (ids[topic], ns, data))
        keys.append(cur.lastrowid)
    db.commit()
    db.close()
    return keys


def metadata_yaml(files, types, counts, all_ns, compression="", mode="", storage="sqlite3"):
    lines = ["rosbag2_bagfile_information:", "  version: 5",
             "  storage_identifier: " + storage, "  relative_file_paths:"]
    lines += ["    - " + f for f, _ in files]
    start = min(all_ns) if all_ns else 0
    lines += ["  duration:", "    nanoseconds: %d" % ((max(all_ns) - start) if all_ns else 0),
              "  starting_time:", "    nanoseconds_since_epoch: %d" % start,
              "  message_count: %d" % len(all_ns), "  topics_with_message_count:"]
    for name in sorted(types):
        lines += ["    - topic_metadata:", "        name: " + name,
                  "        type: " + types[name], "        serialization_format: cdr",
                  "        offered_qos_profiles: " + json.dumps(QOS),
                  "      message_count: %d" % counts.get(name, 0)]
    lines += ['  compression_format: "%s"' % compression, '  compression_mode: "%s"' % mode,
              "  files:"]
    for f, ns in files:
        lines += ["    - path: " + f, "      starting_time:",
                  "        nanoseconds_since_epoch: %d" % (min(ns) if ns else 0),
                  "      duration:", "        nanoseconds: %d" % ((max(ns) - min(ns)) if ns else 0),
                  "      message_count: %d" % len(ns)]
    return "\n".join(lines) + "\n"


def zstd_bytes(data):
    return subprocess.run(["zstd", "-q", "-c"], input=data, check=True,
                          stdout=subprocess.PIPE).stdout


def write_bag(out, name, split, types, compression=""):
    """split: per file, (topic order of its topics table, [(topic, ns, bytes, exp)])."""
    bag = os.path.join(out, name)
    os.makedirs(bag, exist_ok=True)
    files, counts, all_ns, keys = [], {}, [], {}
    for i, (order, msgs) in enumerate(split):
        fname = "%s_%d.db3" % (name, i)
        data = [(t, ns, zstd_bytes(b) if compression == "message" else b) for t, ns, b, _ in msgs]
        rowids = write_db3(os.path.join(bag, fname), order, data, types)
        for (t, ns, _, exp), rowid in zip(msgs, rowids):
            counts[t] = counts.get(t, 0) + 1
            all_ns.append(ns)
            if isinstance(exp, dict):
                exp["file"], exp["id"] = i, rowid
        if compression == "file":
            path = os.path.join(bag, fname)
            subprocess.run(["zstd", "-q", "--rm", "-o", path + ".zstd", path], check=True)
            fname += ".zstd"
        files.append((fname, [ns for _, ns, _, _ in msgs]))
    mode = {"file": "FILE", "message": "MESSAGE"}.get(compression, "")
    with open(os.path.join(bag, "metadata.yaml"), "w") as f:
        f.write(metadata_yaml(files, types, counts, all_ns, "zstd" if mode else "", mode))
    return bag, counts, all_ns


def expected_of(split, types, counts, all_ns, frames):
    exp = {"topics": [], "scans": [], "clouds": [], "transforms": [], "order": [],
           "start": min(all_ns) * 1e-9, "end": max(all_ns) * 1e-9}
    for name in sorted(types):
        exp["topics"].append({"name": name, "type": types[name].replace("/msg/", "/"),
                              "count": counts.get(name, 0), "frame": frames.get(name, "")})
    msgs = sorted(((ns, fi, k, t, e) for fi, (_, ms) in enumerate(split)
                   for k, (t, ns, _, e) in enumerate(ms)), key=lambda m: (m[0], m[1], m[2]))
    for ns, _, _, topic, e in msgs:
        kind = types[topic]
        if kind.startswith("std_msgs"):
            continue  # not a type potmap decodes
        if kind.endswith("LaserScan"):
            exp["scans"].append(dict(e, topic=topic))
        elif kind.endswith("PointCloud2"):
            exp["clouds"].append(dict(e, topic=topic))
        elif kind.endswith("TFMessage"):
            exp["transforms"] += [dict(x, topic=topic) for x in e]
        else:
            exp["transforms"].append(dict(e, topic=topic))
        exp["order"] += [topic] * (len(e) if isinstance(e, list) else 1)
    return exp


def chatter(text):
    c = Cdr()
    c.string(text)
    return c.bytes()


# --- scenarios ---------------------------------------------------------------------------------

T0 = 1700000000 * 10**9  # receive times: a recording of 2023
Q = (0.0, 0.0, math.sin(0.25), math.cos(0.25))


def scan_tf_split():
    """Two files whose receive times interleave, their topics tables in different orders."""
    tf_static = tf_message([(1700000000, 0, "base_link", "laser", (0.2, 0.0, 0.3), (0, 0, 0, 1))],
                           True)
    tf = lambda ms: tf_message([(1700000000, ms * 10**6, "map", "odom", (1.0, 2.0, 0.0), Q),
                                (1700000000, ms * 10**6, "odom", "base_link",
                                 (0.1 * ms, -0.5, 0.0), (0, 0, 0, 1))], False)
    scan = lambda ms, r, big=False: laser_scan(1700000000, ms * 10**6, "laser", r, big)
    m = lambda topic, ms, b_e: (topic, T0 + ms * 10**6 + 5000, b_e[0], b_e[1])
    file0 = (["/scan", "/tf", "/tf_static", "/chatter"],
             [m("/tf_static", 0, tf_static), m("/scan", 10, scan(10, [1.0, 2.5, 3.25, 30.5])),
              m("/tf", 20, tf(20)), ("/chatter", T0 + 30 * 10**6, chatter("hello"), None),
              m("/scan", 110, scan(110, [1.5, NAN, 0.05, 4.0]))])
    file1 = (["/chatter", "/tf", "/scan"],
             [m("/scan", 60, scan(60, [2.0, 2.0, 2.0, 2.0])), m("/tf", 70, tf(70)),
              m("/scan", 160, scan(160, [0.5, 0.75, 1.0, 1.25], True))])
    types = {"/scan": "sensor_msgs/msg/LaserScan", "/tf": "tf2_msgs/msg/TFMessage",
             "/tf_static": "tf2_msgs/msg/TFMessage", "/chatter": "std_msgs/msg/String"}
    return [file0, file1], types, {"/scan": "laser"}


def cloud_split():
    pts = [(1.0, 2.0, 3.0), (NAN, 1.0, 1.0), (0.0, 0.0, 0.0), (-4.5, 0.25, 1e3)]
    c = lambda ms, double, big: point_cloud2(1700000001, ms * 10**6, "velodyne", pts, double, big)
    msgs = [("/points", T0 + (ms + 1000) * 10**6, *c(ms, d, b))
            for ms, d, b in ((0, False, False), (100, True, False), (200, False, True))]
    return [(["/points"], msgs)], {"/points": "sensor_msgs/msg/PointCloud2"}, {
        "/points": "velodyne"}


def misc_split():
    msgs = [("/multi", T0 + 1, *multi_echo(1700000002, 5, "laser2", [[1.0, 1.5], [], [2.0]])),
            ("/odom", T0 + 2, *odometry(1700000002, 6, "odom", "base_link", (1, 2, 3), Q)),
            ("/pose", T0 + 3, *pose_stamped(1700000002, 7, "map", (4, 5, 6), (0, 0, 0, 1)))]
    types = {"/multi": "sensor_msgs/msg/MultiEchoLaserScan", "/odom": "nav_msgs/msg/Odometry",
             "/pose": "geometry_msgs/msg/PoseStamped"}
    return [(["/pose", "/odom", "/multi"], msgs)], types, {
        "/multi": "laser2", "/odom": "odom", "/pose": "map"}


def write_expected(out, name, scenario, compression=""):
    split, types, frames = scenario()
    bag, counts, all_ns = write_bag(out, name, split, types, compression)
    exp = expected_of(split, types, counts, all_ns, frames)
    exp["bag"] = bag
    with open(os.path.join(out, name + ".json"), "w") as f:
        json.dump(exp, f, indent=1)


def write_broken(out, scenario):
    bag = os.path.join(out, scenario)
    os.makedirs(bag, exist_ok=True)
    if scenario == "truncated":
        good, _ = laser_scan(1700000000, 0, "laser", [1.0] * 100)
        cut, _ = laser_scan(1700000000, 5 * 10**8, "laser", [1.0] * 100)
        split = [(["/scan"], [("/scan", T0, good, None), ("/scan", T0 + 5 * 10**8, cut[:200], None)])]
        write_bag(out, scenario, split, {"/scan": "sensor_msgs/msg/LaserScan"})
    elif scenario == "mcap":
        with open(os.path.join(bag, "mcap_0.mcap"), "wb") as f:
            f.write(b"\x89MCAP0\r\n")
        with open(os.path.join(bag, "metadata.yaml"), "w") as f:
            f.write(metadata_yaml([("mcap_0.mcap", [])], {}, {}, [], storage="mcap"))
    elif scenario == "corrupt":
        with open(os.path.join(bag, "corrupt_0.db3"), "wb") as f:
            f.write(b"this is no sqlite database\n" * 200)
        with open(os.path.join(bag, "metadata.yaml"), "w") as f:
            f.write(metadata_yaml([("corrupt_0.db3", [])], {}, {}, []))
    elif scenario == "no_tables":
        db = sqlite3.connect(os.path.join(bag, "no_tables.db3"))
        db.execute("CREATE TABLE readings(id INTEGER PRIMARY KEY, value REAL)")
        db.commit()
        db.close()


def carmen_split(log, limit):
    """A CARMEN log's first `limit` FLASER scans (0: all) as /scan, the robot's pose as /tf odom ->
    base_link at each scan's stamp and the laser 0.25 m ahead on /tf_static: the layout
    write_ros1_bag.py writes for ROS 1, for the same comparison with the log."""
    opener = gzip.open if log.endswith(".gz") else open
    rows = []
    with opener(log, "rt") as f:
        for line in f:
            tok = line.split()
            if not tok or tok[0] != "FLASER":
                continue
            n = int(tok[1])
            rows.append(([float(v) for v in tok[2:2 + n]],
                         *(float(v) for v in tok[2 + n:5 + n]), float(tok[8 + n])))
            if len(rows) == limit:
                break
    largest = max(max(r) for r, *_ in rows)
    ahead = 0.25
    msgs = []
    for k, (ranges, x, y, theta, t) in enumerate(rows):
        sec = int(t)
        nsec = int(round((t - sec) * 1e9))
        ns = sec * 10**9 + nsec
        n = len(ranges)
        inc = math.pi / n if n % 2 == 0 else math.pi / (n - 1)
        q = (0.0, 0.0, math.sin(theta / 2), math.cos(theta / 2))
        base = (x - ahead * math.cos(theta), y - ahead * math.sin(theta), 0.0)
        if k == 0:
            msgs.append(("/tf_static", ns, *tf_message(
                [(sec, nsec, "base_link", "laser", (ahead, 0.0, 0.0), (0, 0, 0, 1))], True)))
        msgs.append(("/tf", ns, *tf_message([(sec, nsec, "odom", "base_link", base, q)], False)))
        msgs.append(("/scan", ns, *laser_scan(sec, nsec, "laser", ranges, amin=-math.pi / 2,
                                              ainc=inc, rmin=0.0, rmax=largest * 0.999)))
    types = {"/scan": "sensor_msgs/msg/LaserScan", "/tf": "tf2_msgs/msg/TFMessage",
             "/tf_static": "tf2_msgs/msg/TFMessage"}
    return [(["/scan", "/tf", "/tf_static"], msgs)], types


def main():
    out, scenario = sys.argv[1], sys.argv[2]
    if scenario == "carmen":
        # write_ros2_bag.py OUT carmen LOG N [file|message]: the bag folder OUT/carmen.
        os.makedirs(out, exist_ok=True)
        split, types = carmen_split(sys.argv[3], int(sys.argv[4]))
        write_bag(out, "carmen", split, types, sys.argv[5] if len(sys.argv) > 5 else "")
        return
    os.makedirs(out, exist_ok=True)
    good = {"scan_tf": (scan_tf_split, ""), "cloud": (cloud_split, ""), "misc": (misc_split, ""),
            "zstd_file": (scan_tf_split, "file"), "zstd_message": (scan_tf_split, "message")}
    if scenario in good:
        write_expected(out, scenario, good[scenario][0], good[scenario][1])
    elif scenario in ("truncated", "mcap", "corrupt", "no_tables"):
        write_broken(out, scenario)
    else:
        sys.exit("unknown scenario " + scenario)


if __name__ == "__main__":
    main()
