#!/usr/bin/env bash
# Installs the build into a temporary prefix and builds a small program against it twice: with
# CMake's find_package(sandmpm) (shared and static targets) and with pkg-config. Each program runs
# a few steps and checks the library's version string.
#   tests/test_install.sh BUILD_DIR SOURCE_DIR C_COMPILER
set -euo pipefail
build=$1
src=$2
cc=$3
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cmake --install "$build" --prefix "$tmp/prefix" >/dev/null
mkdir -p "$tmp/consumer"
cat >"$tmp/consumer/main.c" <<'C'
#include <stdio.h>
#include <string.h>
#include "sandmpm/sandmpm.h"
int main(void) {
    sm_world_def def = sm_world_def_default();
    def.dim = 2;
    def.dx = 0.05;
    sm_world *w;
    if (sm_world_create(&def, &w, NULL, 0) != SM_OK) return 1;
    sm_material_def m = sm_material_def_sand();
    int mat;
    if (sm_world_add_material(w, &m, &mat) != SM_OK) return 1;
    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    box.center[0] = box.center[1] = 0.5;
    box.half_extent[0] = box.half_extent[1] = 0.2;
    sm_seed_def sd = sm_seed_def_default();
    sd.material = mat;
    size_t n = 0;
    if (sm_world_seed_shape(w, &box, &sd, &n) != SM_OK || n == 0) return 1;
    if (sm_world_advance(w, 0.01) != SM_OK) return 1;
    printf("sandmpm %s: %zu particles, t = %g\n", sm_version(), n, sm_world_time(w));
    sm_world_destroy(w);
    return strcmp(sm_version(), "") == 0;
}
C
cat >"$tmp/consumer/CMakeLists.txt" <<'CM'
cmake_minimum_required(VERSION 3.16)
project(consumer C)
find_package(sandmpm REQUIRED)
add_executable(consumer_shared main.c)
target_link_libraries(consumer_shared PRIVATE sandmpm::sandmpm)
add_executable(consumer_static main.c)
target_link_libraries(consumer_static PRIVATE sandmpm::sandmpm_static)
CM
cmake -S "$tmp/consumer" -B "$tmp/consumer/build" -DCMAKE_C_COMPILER="$cc" -DCMAKE_PREFIX_PATH="$tmp/prefix" >/dev/null
cmake --build "$tmp/consumer/build" >/dev/null
LD_LIBRARY_PATH="$tmp/prefix/lib" "$tmp/consumer/build/consumer_shared"
"$tmp/consumer/build/consumer_static"
# The shared program really uses the installed libsandmpm.so.
LD_LIBRARY_PATH="$tmp/prefix/lib" ldd "$tmp/consumer/build/consumer_shared" | grep "$tmp/prefix/lib/libsandmpm.so" >/dev/null
export PKG_CONFIG_PATH="$tmp/prefix/lib/pkgconfig"
# shellcheck disable=SC2046
"$cc" -o "$tmp/consumer/pc" "$tmp/consumer/main.c" $(pkg-config --cflags --libs sandmpm)
LD_LIBRARY_PATH="$tmp/prefix/lib" "$tmp/consumer/pc"
# shellcheck disable=SC2046
"$cc" -o "$tmp/consumer/pc_static" "$tmp/consumer/main.c" $(pkg-config --static --cflags sandmpm) \
    "$tmp/prefix/lib/libsandmpm.a" $(pkg-config --static --libs-only-l --libs-only-other sandmpm | sed 's/-lsandmpm//')
"$tmp/consumer/pc_static"
test -x "$tmp/prefix/bin/sandmpm"
echo "test_install: find_package (shared, static) and pkg-config (shared, static) consumers ran"
