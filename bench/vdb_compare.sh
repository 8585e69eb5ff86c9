#!/usr/bin/env bash
# Builds and runs bench/vdb_compare.cpp (the mesh field against OpenVDB's meshToLevelSet) against
# a configured build directory. Optional: needs Debian's libopenvdb-dev (apt-get install
# libopenvdb-dev) and g++; not part of scripts/test.sh (OpenVDB's headers take a minute to compile,
# and a C++ target in the CMake project would need C++ enabled for every build).
#   bash bench/vdb_compare.sh BUILD_DIR [spacing]
set -euo pipefail
cd "$(dirname "$0")/.."
B=${1:?usage: bench/vdb_compare.sh BUILD_DIR [spacing]}
if [ ! -f /usr/include/openvdb/tools/MeshToVolume.h ]; then
    echo "vdb_compare: OpenVDB not installed (apt-get install libopenvdb-dev); skipped" >&2
    exit 0
fi
cmake --build "$B" --target sandmpm -j2 >/dev/null
OUT="$B/vdb_compare"
gcc -O2 -c -Itests tests/mesh_gen.c -o "$B/vdb_mesh_gen.o"
g++ -O2 -std=c++17 -w -Iinclude -I"$B/include" -Isrc -Itests bench/vdb_compare.cpp "$B/vdb_mesh_gen.o" \
    "$B/libsandmpm.a" -lopenvdb -ltbb -lImath-3_1 -lm -fopenmp -o "$OUT"
"$OUT" "${@:2}"
