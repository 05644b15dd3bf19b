#!/usr/bin/env bash
# Builds the libFuzzer targets of tests/fuzz with clang (ASan + UBSan) in build-fuzz and runs each one
# for a while on a seed corpus made from tests/fixtures, small generated files and the regression
# inputs of tests/fixtures/fuzz.
#   tools/fuzz.sh                     every target, 60 s each (the CI step)
#   FUZZ_SECONDS=3600 tools/fuzz.sh   the longer run (an hour per target)
#   tools/fuzz.sh surface config      only these targets (surface tetmesh hexmesh config)
# Environment: FUZZ_SECONDS (per target, default 60), JOBS (build, default 2), BUILD_DIR (default
# build-fuzz), FUZZ_JOBS (parallel fuzzing processes per target, default 1).
# A crash stops nothing: every target runs, then the script lists the crashing inputs (in
# BUILD_DIR/artifacts) and exits 1. Turn a crash into a regression fixture: copy the input to
# tests/fixtures/fuzz/<target>/<name> (see tests/tools/test_fuzz_regressions.cpp) after fixing the reader.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
BUILD_DIR=${BUILD_DIR:-build-fuzz}
JOBS=${JOBS:-2}
FUZZ_SECONDS=${FUZZ_SECONDS:-60}
FUZZ_JOBS=${FUZZ_JOBS:-1}
ALL_TARGETS=(surface tetmesh hexmesh config)
TARGETS=("$@")
[ ${#TARGETS[@]} -eq 0 ] && TARGETS=("${ALL_TARGETS[@]}")

command -v clang++ >/dev/null || { echo "fuzz.sh: clang++ not found (apt-get install clang libclang-rt-14-dev)"; exit 2; }

# --- build (only the fuzz targets and the sources they link)
CC=clang CXX=clang++ cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPOLYHEX_FUZZ=ON \
  -DPOLYHEX_BUILD_TESTS=OFF >/dev/null
cmake --build "$BUILD_DIR" -j "$JOBS" --target $(printf 'fuzz_%s ' "${TARGETS[@]}")

# --- seed corpora: byte 0 selects the reader's extension (see tests/fuzz/fuzz_common.h)
SEEDS="$BUILD_DIR/seeds"
rm -rf "$SEEDS"
mkdir -p "$SEEDS"/{surface,tetmesh,hexmesh,config}
python3 - "$ROOT" "$SEEDS" <<'PY'
import glob, os, struct, sys
root, seeds = sys.argv[1], sys.argv[2]
fx = os.path.join(root, "tests", "fixtures", "io")
def put(target, name, selector, data):
    with open(os.path.join(seeds, target, name), "wb") as f:
        f.write(bytes([selector]) + data)
def read(name):
    with open(os.path.join(fx, name), "rb") as f:
        return f.read()
# surface: 0 .obj, 1 .off, 2 .stl, 3 .ply
for name in os.listdir(fx):
    ext = os.path.splitext(name)[1]
    if ext in (".obj", ".off", ".stl", ".ply"):
        put("surface", name, [".obj", ".off", ".stl", ".ply"].index(ext), read(name))
tet_v = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
tet_f = [(0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)]
def normal(a, b, c):
    u = [b[i] - a[i] for i in range(3)]; v = [c[i] - a[i] for i in range(3)]
    return (u[1]*v[2]-u[2]*v[1], u[2]*v[0]-u[0]*v[2], u[0]*v[1]-u[1]*v[0])
stl = b"binary tetra".ljust(80, b" ") + struct.pack("<I", len(tet_f))
for f in tet_f:
    p = [tet_v[i] for i in f]
    stl += struct.pack("<12fH", *normal(*p), *p[0], *p[1], *p[2], 0)
put("surface", "tetra_binary.stl", 2, stl)
for fmt, endian in (("binary_little_endian", "<"), ("binary_big_endian", ">")):
    ply = (f"ply\nformat {fmt} 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
           "element face 4\nproperty list uchar int vertex_indices\nend_header\n").encode()
    for v in tet_v: ply += struct.pack(endian + "3f", *v)
    for f in tet_f: ply += struct.pack(endian + "B3i", 3, *f)
    put("surface", f"tetra_{fmt}.ply", 3, ply)
put("surface", "tetra.off", 1, b"OFF\n4 4 0\n" + b"".join(b"%d %d %d\n" % v for v in tet_v) +
    b"".join(b"3 %d %d %d\n" % f for f in tet_f))
# tetmesh: 0 .mesh, 1 .vtk, 2 .msh, 3 .node + NUL + .ele
put("tetmesh", "two_tets.mesh", 0, read("two_tets.mesh"))
put("tetmesh", "two_tets.vtk", 1, read("two_tets.vtk"))
put("tetmesh", "two_tets_v22.msh", 2, read("two_tets_v22.msh"))
put("tetmesh", "two_tets_v41.msh", 2, read("two_tets_v41.msh"))
put("tetmesh", "two_tets.node", 3, read("two_tets.node") + b"\0" + read("two_tets.ele"))
vtk = b"# vtk DataFile Version 2.0\ntet\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n"
vtk += b"".join(struct.pack(">3d", *v) for v in tet_v)
vtk += b"\nCELLS 1 5\n" + struct.pack(">5i", 4, 0, 1, 2, 3) + b"\nCELL_TYPES 1\n" + struct.pack(">i", 10) + b"\n"
put("tetmesh", "tet_binary.vtk", 1, vtk)
# hexmesh: 0 .vtk, 1 .mesh, 2 .msh
put("hexmesh", "unit_hex.vtk", 0, read("unit_hex.vtk"))
put("hexmesh", "unit_hex.mesh", 1, read("unit_hex.mesh"))
cube = [(x, y, z) for z in (0, 1) for y in (0, 1) for x in (0, 1)]
order = [0, 1, 3, 2, 4, 5, 7, 6]
msh = b"$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 8 1 8\n3 1 0 8\n" + b"".join(b"%d\n" % (i + 1) for i in range(8))
msh += b"".join(b"%d %d %d\n" % c for c in cube) + b"$EndNodes\n$Elements\n1 1 1 1\n3 1 5 1\n1 "
msh += b" ".join(b"%d" % (i + 1) for i in order) + b"\n$EndElements\n"
put("hexmesh", "unit_hex.msh", 2, msh)
vtkh = b"# vtk DataFile Version 2.0\nhex\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 8 double\n"
vtkh += b"".join(struct.pack(">3d", *c) for c in cube)
vtkh += b"\nCELLS 1 9\n" + struct.pack(">9i", 8, *order) + b"\nCELL_TYPES 1\n" + struct.pack(">i", 12) + b"\n"
put("hexmesh", "hex_binary.vtk", 0, vtkh)
# config: the shipped configs and small ones reaching the graph checks
for path in glob.glob(os.path.join(root, "configs", "*.json")):
    with open(path, "rb") as f:
        data = f.read()
    with open(os.path.join(seeds, "config", os.path.basename(path)), "wb") as f:
        f.write(data)
small = {
    "fuzz_params.json": b'{"nodes": [{"id": "s", "type": "read_surface", "params": {"path": "${input}"}},'
                        b' {"id": "p", "type": "fuzz/params", "params": {"x": 2.5, "n": 7, "flag": true, "name": "b",'
                        b' "mode": "two"}, "inputs": ["s"]}, {"id": "w", "type": "write_hex", "inputs": {"mesh": "p"}}]}',
    "cycle.json": b'{"nodes": [{"id": "a", "type": "fuzz/params", "inputs": {"surface": "b"}},'
                  b' {"id": "b", "type": "fuzz/params", "inputs": {"surface": "a"}}]}',
    "vars.json": b'{"description": "${x:-d}", "nodes": [{"id": "s", "type": "read_surface", "params": {"path": "${input:-a.off}"}}]}',
}
for name, data in small.items():
    with open(os.path.join(seeds, "config", name), "wb") as f:
        f.write(data)
PY
# (tests/fixtures/fuzz holds the crashes found so far; they are not seeds: the Catch2 test
# tests/tools/test_fuzz_regressions.cpp runs them, and as seeds they would stop a target at once.)

# --- run
ARTIFACTS="$BUILD_DIR/artifacts"
mkdir -p "$ARTIFACTS"
failed=()
summary=""
for t in "${TARGETS[@]}"; do
  corpus="$BUILD_DIR/corpus/$t"
  mkdir -p "$corpus"
  log="$BUILD_DIR/fuzz_$t.log"
  parallel=""
  [ "$FUZZ_JOBS" -gt 1 ] && parallel="-jobs=$FUZZ_JOBS -workers=$FUZZ_JOBS"
  echo "fuzz.sh: fuzz_$t for ${FUZZ_SECONDS} s (log: $log)"
  set +e
  # -rss_limit_mb / -malloc_limit_mb: an input that makes a reader allocate gigabytes is a finding.
  ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=0 UBSAN_OPTIONS=print_stacktrace=1 \
    "$BUILD_DIR/tests/fuzz/fuzz_$t" -max_total_time="$FUZZ_SECONDS" -timeout=10 -rss_limit_mb=2048 \
    -malloc_limit_mb=1024 $parallel -print_final_stats=1 \
    -artifact_prefix="$ARTIFACTS/$t-" "$corpus" "$SEEDS/$t" >"$log" 2>&1
  rc=$?
  set -e
  [ "$FUZZ_JOBS" -gt 1 ] && cat fuzz-*.log >>"$log" 2>/dev/null && rm -f fuzz-*.log
  execs=$(grep -h "stat::number_of_executed_units" "$log" | awk '{s += $2} END {print s + 0}')
  cov=$(grep -ho "cov: [0-9]*" "$log" | tail -1 | awk '{print $2}')
  summary+=$(printf '%-8s %10s executions  %6s s  coverage %-6s corpus %5s files  exit %s' "$t" "$execs" \
    "$FUZZ_SECONDS" "${cov:-?}" "$(ls "$corpus" | wc -l)" "$rc")$'\n'
  if [ $rc -ne 0 ]; then
    failed+=("$t")
    grep -h -m3 -E "ERROR: |runtime error:|Test unit written to" "$log" || tail -20 "$log"
  fi
done
printf '%s' "$summary"
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz.sh: findings in: ${failed[*]}; inputs in $ARTIFACTS:"
  ls -l "$ARTIFACTS"
  exit 1
fi
echo "fuzz.sh: no crash in ${TARGETS[*]}"
