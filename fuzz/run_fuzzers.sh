#!/usr/bin/env bash
# Builds the libFuzzer targets with clang and runs each for SECONDS (default 20) from a seed
# corpus taken from ../shared/data where present, one per core at a time (POTMAP_FUZZ_JOBS).
# Exits non-zero when any crashed.
# Usage: fuzz/run_fuzzers.sh [SECONDS] [BUILD_DIR]
set -euo pipefail
secs=${1:-20}
root=$(cd "$(dirname "$0")/.." && pwd)
build=${2:-$root/build-fuzz}
# shellcheck source=scripts/sanitizer_build.sh
source "$root/scripts/sanitizer_build.sh"
sanitizer_configure "$root" "$build"
targets="carmen velodyne kitti_poses npz map_csv map_npz map_potmap labelled_csv dictionary tuning_file
  point_cloud point_cloud_poses drive ros2_bag ros1_bag"
make -C "$build" -j2 $(for t in $targets; do printf 'fuzz_%s ' "$t"; done) >/dev/null
data=$root/../shared/data
corpus=$build/corpus
for t in $targets; do mkdir -p "$corpus/$t"; done
# Small seeds: the head of a real log, a slice of a real frame.
if [ -d "$data/radish" ]; then
  zcat "$data/radish/intel-corrected.log.gz" | head -c 20000 > "$corpus/carmen/intel_head.log" || true
fi
# One seed per other laser line kind the reader chooses between (a log is read from one kind).
printf 'RLASER 3 1 2 3 1 2 0 1 2 0 3.5 h 3.5\nFLASER 2 1 2 0 0 0 0 0 0\nRLASER 2 1 2 0 0 0 0 0 0\n' \
  > "$corpus/carmen/rlaser.log"
printf 'ODOM 0 0 3 0 0 0 10 h 10\nRAWLASER1 0 -1.57 3.14 0.01 8 0.01 0 3 1 2 9 1 5 10.5 h 10.5\nRAWLASER2 0 0 0 0 8 0 0 1 1 0 11 h 11\nODOM 2 4 -3 0 0 0 12 h 12\n' \
  > "$corpus/carmen/rawlaser.log"
printf 'ROBOTLASER1 0 0 1 1 8 0.01 0 2 1 2 0 0 0 0 0 0 0 0 0 0 0 0 7 h 7\nROBOTLASER1 0 0 1 1 8 0.01 0 2 1 2 0 1 0 0 1 0 0 8 h 8\nROBOTLASER1 0 0 1 1 8 0.01 0 2 1 2 0 1 0 0 1 0 0\n' \
  > "$corpus/carmen/robotlaser.log"
printf 'ODOM 1 2 1.57 0 0 0 5 h 5\nLASER 2 3 4 6 h 6\nODOM 2 2 0\nLASER3 2 1 1\nLASER 2 1 1\n' \
  > "$corpus/carmen/oldlaser.log"
if [ -f "$data/lidar3d/kitti_000008.bin" ]; then
  head -c 1600 "$data/lidar3d/kitti_000008.bin" > "$corpus/velodyne/kitti_head.bin"
fi
printf 'Tr: 1 0 0 0 0 1 0 0 0 0 1 0\n\0001 0 0 0 0 1 0 0 0 0 1 0\n' > "$corpus/kitti_poses/seed"
printf '1 0 0 0 0 1 0 0 0 0 1 0\n\000100.5\n' > "$corpus/drive/seed"
# A tiny valid .npz (X: 2 x 3 float64, Y: 2 uint8) so the npz fuzzer starts past the zip layer.
if command -v python3 >/dev/null; then
  python3 - "$corpus/npz/seed.npz" <<'PY'
import struct, sys, zipfile
def npy(descr, shape, body):
    h = "{'descr': '%s', 'fortran_order': False, 'shape': %s, }" % (descr, shape)
    h += " " * ((64 - (10 + len(h) + 1) % 64) % 64) + "\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(h)) + h.encode() + body
with zipfile.ZipFile(sys.argv[1], "w") as z:
    z.writestr("X.npy", npy("<f8", "(2, 3)", struct.pack("<6d", 0, 1, 2, 1, 3, 4)))
    z.writestr("Y.npy", npy("|u1", "(2,)", b"\x01\x00"))
PY
fi
if [ -d "$data/carla" ]; then
  head -c 4000 "$data/carla/town1_abhm_map.csv" > "$corpus/map_csv/town1_head.csv"
  head -c 4000 "$data/carla/town1_test2k.csv" > "$corpus/labelled_csv/test_head.csv"
fi
printf 'x,y,z,gamma,w_mean,w_var\n# bias 0.5 2\n1,2,3,0.5,1,2\n' > "$corpus/map_csv/seed3d.csv"
printf 'POTMAP' > "$corpus/map_potmap/seed"
# Point clouds: a tiny ASCII PCD, a binary PCD and an ASCII PLY (PCL's headers, hand-written
# so that the corpus needs no PCL tool); poses naming the frame the poses fuzzer writes.
printf 'VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA ascii\n1 2 3\nnan 5 6\n' \
  > "$corpus/point_cloud/ascii.pcd"
{ printf 'VERSION .7\nFIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA binary\n'
  head -c 32 /dev/zero; } > "$corpus/point_cloud/binary.pcd"
printf 'ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n4 5 6\n' \
  > "$corpus/point_cloud/ascii.ply"
printf '# frame pose\npotmap-fuzz-frame.pcd 1 0 0 0 0 1 0 0 0 0 1 0\n/tmp/potmap-fuzz-frame.pcd 0 -1 0 1 1 0 0 2 0 0 1 3\n' \
  > "$corpus/point_cloud_poses/seed"
# A valid one-atom 2D dictionary (layout: include/potmap/pot/dictionary_io.hpp), so that the
# dictionary fuzzer starts past the checksum.
if command -v python3 >/dev/null; then
  python3 - "$corpus/dictionary/seed.potdict" <<'PY'
import struct, sys, zlib
src = b"seed"
atom = struct.pack("<iI6d2dq3QII", 1, 0, 1, 2, 0, 0, 0, 0, 0.02, 20, 3, 2, 1, 1, len(src), 0)
atom += src + struct.pack("<4d2d2d3d", .1, .2, -.1, -.2, .05, .05, 0, .1, 2.0, 1.5, 3.0)
size = 64 + len(atom) + 4
body = b"POTDIC\r\n" + struct.pack("<II2dIIQQQ", 1, 2, 0.02, 20, 5, 0, 1, size, 0) + atom
open(sys.argv[1], "wb").write(body + struct.pack("<I", zlib.crc32(body)))
PY
fi
# One CDR body of each ROS 2 type, encoded by the tests' bag writer, behind its type byte.
if command -v python3 >/dev/null; then
  python3 - "$corpus/ros2_bag" "$root/tests/data" <<'PY'
import sys
sys.path.insert(0, sys.argv[2])
import write_ros2_bag as w
q = (0, 0, 0, 1)
bodies = [w.laser_scan(1, 2, "laser", [1.0, float("nan"), 2.0])[0],
          w.multi_echo(1, 2, "laser", [[1.0, 2.0], [], [3.0]])[0],
          w.point_cloud2(1, 2, "lidar", [(1.0, 2.0, 3.0), (0.0, 0.0, 0.0)], True, True)[0],
          w.tf_message([(1, 2, "odom", "base", (1, 2, 3), q)], False)[0],
          w.odometry(1, 2, "odom", "base", (1, 2, 3), q)[0],
          w.pose_stamped(1, 2, "map", (1, 2, 3), q)[0]]
for i, b in enumerate(bodies):
    open("%s/seed%d" % (sys.argv[1], i), "wb").write(bytes([i]) + b)
PY
fi
# Two small ROS 1 bags written by ROS's own tools (Debian's python3-rosbag).
if /usr/bin/python3 -c "import rosbag" 2>/dev/null; then
  /usr/bin/python3 "$root/tests/data/write_ros1_bag.py" clouds --clouds 2 "$corpus/ros1_bag/clouds.bag"
  if [ -d "$data/radish" ]; then
    /usr/bin/python3 "$root/tests/data/write_ros1_bag.py" carmen "$data/radish/intel-corrected.log.gz" \
      --scans 3 "$corpus/ros1_bag/scans.bag"
  fi
fi
cp "$corpus/npz/seed.npz" "$corpus/map_npz/seed.npz" 2>/dev/null || true
# A tuning file for the fuzzer's fixed device (fuzz_tuning_file.cpp), this source's version.
version=$(sed -n 's/^project(potmap VERSION \([0-9.]*\).*/\1/p' "$root/CMakeLists.txt")
printf 'potmap-tuning 1\npotmap_version %s\nplatform P\nplatform_version V\ndevice D\ndriver 1\ntuning raster.rows_per_item=16,sinkhorn.work_group=2\n' "$version" > "$corpus/tuning_file/seed"
# One fuzzer per core at a time (each is single-threaded), each with its own log, printed in
# order once all are done; the first crash fails the run.
jobs=${POTMAP_FUZZ_JOBS:-$(nproc)}
logs=$build/fuzz-logs
mkdir -p "$logs"
fuzz_one() {
  "$build/fuzz/fuzz_$1" -seed=1 -artifact_prefix="$build/" -max_total_time="$secs" -max_len=65536 \
    -rss_limit_mb=2048 "$corpus/$1" >"$logs/$1.log" 2>&1
}
declare -A pid_of
failed=()
running=0
for t in $targets; do
  if ((running >= jobs)); then
    wait -n || true
    running=$((running - 1))
  fi
  fuzz_one "$t" &
  pid_of[$t]=$!
  running=$((running + 1))
done
for t in $targets; do
  status=0
  wait "${pid_of[$t]}" || status=$?
  echo "fuzz_$t: ${secs} s"
  tail -3 "$logs/$t.log"
  ((status == 0)) || failed+=("fuzz_$t (exit $status, log $logs/$t.log)")
done
if ((${#failed[@]})); then
  echo "fuzzing found crashes: ${failed[*]}" >&2
  exit 1
fi
echo "no crashes"
