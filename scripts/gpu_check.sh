#!/usr/bin/env bash
# The GPU checks in one prepared run, on a machine with an NVIDIA driver and nothing of
# potmap's build (scripts/gpu_bundle.sh packs what it needs into .dev/; run this from the
# checkout's root there): finds the driver's OpenCL library and registers it with the bundled
# ICD loader, runs the test suite on the GPU (sharded), docs/performance.md's benchmarks, POT
# at 200 atoms on town2 (pipelined and one scan at a time), the 3D drive benchmarks (the joint
# BHM against OctoMap per keyframe, and whole drives: the job against its keyframes' time), the
# tuning sweep, and raster jobs end to end. Every stage has its own limit inside BUDGET seconds (default 560); the log goes to
# $OUT/run.log and stdout, results (at most 8 files) to $OUT.
# LOCAL_DRY=1 runs the same stages on this machine's default device (a check of the script).
set -u -o pipefail
T0=$(date +%s)
BUDGET=${BUDGET:-560}
R=$PWD
OUT=${OUT:-/tmp/out}
mkdir -p "$OUT"
exec > >(tee -a "$OUT/run.log") 2>&1
exec 3>&1  # stage lines reach the log even from inside a filtered pipeline
now() { echo $(($(date +%s) - T0)); }
stage() { # stage NAME SECONDS CMD...: runs CMD under a limit clipped to what is left
  local name=$1 t=$2
  shift 2
  local l=$((BUDGET - $(now) - 5))
  [ "$t" -gt "$l" ] && t=$l
  if [ "$t" -lt 5 ]; then
    echo "== $name: skipped, no time left" >&3
    return 99
  fi
  echo "== $name (limit $t s) at +$(now) s" >&3
  local s=$(date +%s%N)
  timeout -k 5 "$t" "$@"
  local rc=$?
  echo "== $name rc=$rc after $((($(date +%s%N) - s) / 1000000)) ms" >&3
  return $rc
}

B=/tmp/pb
mkdir -p $B && tar -xJf .dev/bundle.tar.xz -C $B || exit 1
export LD_LIBRARY_PATH=$B/lib
# The tests' compiled-in paths: the checkout at /work/main, the data at /work/main/../shared.
[ -e ../shared ] || ln -sfn "$R/.dev/shared" ../shared
if [ "$R" != /work/main ] && [ ! -e /work/main ]; then mkdir -p /work && ln -sfn "$R" /work/main; fi
ls -d /work/main/../shared/data/carla >/dev/null || echo "WARNING: /work/main/../shared/data missing"
mkdir -p build/tools build/bench build/tests
cp $B/bin/potmap build/tools/ && cp $B/bin/potmap_bench $B/bin/pot_scale $B/bin/mapper_latency build/bench/
cp $B/lib/libpotmap.so.0 build/
echo "repo $R; $(nproc) cores; $(grep PRETTY /etc/os-release)"
nvidia-smi -L 2>&1 | head -3
nvidia-smi --query-gpu=name,driver_version,clocks.max.sm,memory.total --format=csv 2>&1 | head -3

if [ -z "${LOCAL_DRY:-}" ]; then
  NV=""
  for d in /usr/local/nvidia/lib64 /usr/local/nvidia/lib /usr/lib/x86_64-linux-gnu /usr/lib64 /usr/local/cuda/compat /usr/local/cuda/lib64; do
    f=$(ls $d/libnvidia-opencl.so.1 $d/libnvidia-opencl.so.* 2>/dev/null | head -1)
    [ -n "$f" ] && NV=$f && break
  done
  [ -z "$NV" ] && NV=$(timeout 40 find / -xdev \( -path /proc -o -path /sys \) -prune -o -name 'libnvidia-opencl.so*' -print 2>/dev/null | head -1)
  echo "NVIDIA OpenCL library: ${NV:-none}; system vendors: $(ls /etc/OpenCL/vendors 2>/dev/null)"
  [ -z "$NV" ] && { ls /usr/local/nvidia/lib64 2>/dev/null | head -50; exit 2; }
  mkdir -p /tmp/icd && echo "$NV" >/tmp/icd/nvidia.icd
  export OCL_ICD_VENDORS=/tmp/icd
  export LD_LIBRARY_PATH=$B/lib:$(dirname "$NV")
  if ! build/tools/potmap devices 2>&1 | tee /tmp/devices.txt | grep -q -i nvidia; then
    echo "-- not through OCL_ICD_VENDORS; trying OCL_ICD_FILENAMES"
    export OCL_ICD_FILENAMES=$NV
    build/tools/potmap devices 2>&1 | tee /tmp/devices.txt
    grep -q -i nvidia /tmp/devices.txt || {
      ldd "$NV"
      OCL_ICD_DEBUG=15 build/tools/potmap devices 2>&1 | tail -30
      exit 3
    }
  fi
  export POTMAP_DEVICE=NVIDIA
else
  build/tools/potmap devices
fi

export POTMAP_CACHE_DIR=/tmp/kc XDG_CACHE_HOME=/tmp/uc
mkdir -p /tmp/kc /tmp/uc

# 1. Correctness: the suite (less its GeoTIFF tests: GDAL does not travel) on the GPU, sharded.
FILTER='-RasterTiles.*:RasterTilesCli.*:WriteFaults.RasterGeoTiffAndManifest:WriteFaults.RasterTiles'
FILTER+=':DriveReader.IndexesTheRiversideDriveAsItIs:DriveReader.SummarisesBothSharedDrives'
run_tests() {
  local n=${SHARDS:-12} i
  for i in $(seq 0 $((n - 1))); do
    (cd build/tests && GTEST_TOTAL_SHARDS=$n GTEST_SHARD_INDEX=$i $B/bin/potmap_tests_nogdal \
      --gtest_filter="$FILTER" >/tmp/t$i.log 2>&1; echo "shard $i rc=$?" >>/tmp/t$i.log) &
  done
  (cd build/tests && $B/bin/potmap_capi_tests >/tmp/tcapi.log 2>&1; echo "capi rc=$?" >>/tmp/tcapi.log) &
  wait
}
export -f run_tests
export B FILTER
stage tests "${T_TESTS:-130}" bash -c run_tests
cat /tmp/t*.log >"$OUT/tests.log" 2>/dev/null
grep -h -E "rc=|^\[  PASSED  \]" /tmp/t*.log | tr '\n' ' '
echo
grep -h -E "^\[  FAILED  \] [A-Za-z]" /tmp/t*.log | sort -u | head -60
grep -h -E "^\[ RUN      \]" /tmp/t*.log >/tmp/started.txt
grep -h -E "^\[       OK \]|^\[  FAILED  \]|^\[  SKIPPED \]" /tmp/t*.log | wc -l | xargs echo "finished tests:"

# 2. docs/performance.md's tables on the GPU (the CPU reference rows on this machine's 16 cores).
stage bench_town1 "${T_TOWN1:-70}" build/bench/potmap_bench \
  '--benchmark_filter=^BM_Town1(GridOpenCL/|GridOpenCLFine|PointsOpenCL|Reference)' \
  --benchmark_min_time=0.3 --benchmark_out="$OUT/bench_gpu_town1.json" --benchmark_out_format=json 2>&1 |
  grep -E "^BM_|rror" | cut -c1-220
stage bench "${T_BENCH:-100}" build/bench/potmap_bench \
  '--benchmark_filter=^BM_(EvalPointsOpenCL/(1000|10000|100000)/(1000000|10000000)/|SinkhornOpenCL/(1|36|270|512)/200/0/|SinkhornOpenCL/(1|8)/1500/0/|SinkhornScan|PotOpenCL/atoms:200/rotations:8/refine:./candidates:0/indexed:1|BhmUpdate/(10000|50000)/0|AbhmStep)' \
  --benchmark_min_time=0.2 --benchmark_out="$OUT/bench_gpu.json" --benchmark_out_format=json 2>&1 |
  grep -E "^BM_|rror" | cut -c1-220

# 2b. 3D drives on the GPU: the joint BHM (sums on the device) against OctoMap, keyframes 10-29 at
# both cuts, then whole drives as users run them (riverside-a: its first 60 keyframes travel).
stage drive3d "${T_DRIVE:-110}" python3 bench/drive3d.py --build build --drives riverside-a,hku-1 \
  --methods ogm,bhm --mapping bhm --out /tmp/drive3d_gpu.json 2>&1 | grep -E "^\||rror"
stage drive_job "${T_DRIVE_JOB:-90}" python3 bench/drive_memory.py --build build \
  --drives hku-1,riverside-a --out /tmp/drive_job_gpu.json 2>&1 | grep -E "^\||Device|rror"

# 3. POT per scan, town2, 200 atoms (the row), pipelined and one scan at a time.
stage pot_scale "${T_POT:-70}" build/bench/pot_scale --target town2 --atoms 200 \
  --exhaustive-scans 20 --repot 1 --cache .dev/ps_cache --out "$OUT/pot_scale_gpu.json" 2>&1 | tail -25
# 5. The tuning sweep: the GPU's best settings (full sweep, else the quick one).
stage tune "${T_TUNE:-140}" build/tools/potmap tune --dir /tmp/tune --out "$OUT/sweep_gpu" 2>&1 | tail -40 ||
  stage tune_quick 60 build/tools/potmap tune --quick --dir /tmp/tune --out "$OUT/sweep_gpu" 2>&1 | tail -40
cat /tmp/tune/* 2>/dev/null | head -40
stage pot_scale_p0 "${T_POT0:-40}" build/bench/pot_scale --target town2 --atoms 200 \
  --exhaustive-scans 0 --repot 0 --pipeline 0 --cache .dev/ps_cache --out /tmp/pot_scale_gpu_p0.json 2>&1 | tail -12
stage mapper_latency "${T_ML:-40}" build/bench/mapper_latency --dict .dev/ps_cache/town2_first10_200.potdict \
  --target town2 --out "$OUT/mapper_latency_gpu.json" 2>&1 | tail -12

# 4. Raster end to end, PNG + .npy (whole process), 0.25 m and 0.05 m, 3 runs each.
raster_e2e() {
  local map=/work/main/../shared/data/carla/town1_abhm_map.csv res i
  local b=$(python3 -c "
import sys
xs=[];ys=[]
for i,l in enumerate(open('$map')):
    if i==0: continue
    x,y=l.split(',')[:2]; xs.append(float(x)); ys.append(float(y))
print('%r,%r,%r,%r'%(min(xs),max(xs),min(ys),max(ys)))")
  for res in 0.25 0.05; do
    for i in 1 2 3; do
      local s=$(date +%s%N)
      build/tools/potmap raster --map $map --bounds "$b" --res $res --out /tmp/r$res --json >/tmp/rj.json 2>/dev/null
      echo "raster res=$res run=$i rc=$? wall_ms=$((($(date +%s%N) - s) / 1000000)) $(head -c 400 /tmp/rj.json | tr '\n' ' ')"
    done
  done
}
export -f raster_e2e
stage raster "${T_RASTER:-50}" bash -c raster_e2e

echo "== done at +$(now) s"
