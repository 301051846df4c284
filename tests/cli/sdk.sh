#!/usr/bin/env bash
# The installed SDK (issue 10): cmake --install into a temporary prefix, then the examples in
# examples/embed build against it with find_package(csi) (and with pkg-config), and the one that
# reconstructs a dump gives the same pixels, bit for bit, as csi-reconstruct and csi-render on
# that dump; the shared library exports the public API only; the install holds the two public
# headers and nothing else of the source tree's.
# usage: sdk.sh BUILD_DIR SOURCE_DIR
set -u
B="$1"; S="$2"
source "$(dirname "${BASH_SOURCE[0]}")/../support/testlib.sh"

cmake --install "$B" --prefix "$T/prefix" > "$T/install.log" 2>&1
check "[[ $? == 0 ]]" "cmake --install: $(tail -3 "$T/install.log")"
lib="$(find "$T/prefix" -name 'libcsi.so' | head -1)"
check "[[ -n '$lib' && -n \"\$(find '$T/prefix' -name libcsi.a)\" ]]" "shared and static libraries installed"
headers="$(cd "$T/prefix/include" && find . -type f | sort | tr '\n' ' ')"
check "[[ '$headers' == './csi/csi.h ./csi/csi_opencl.h ' ]]" "installed headers: $headers"
# exported: csi_ names only, the public API's (an internal one such as csi_fail is hidden)
nm -D --defined-only "$lib" | awk '$2 ~ /[TDBR]/ {print $3}' | sort > "$T/exported"
check "! grep -qv '^csi_' '$T/exported'" "non-csi symbols exported: $(grep -v '^csi_' "$T/exported" | head -3)"
check "grep -qx csi_reconstruct '$T/exported' && grep -qx csi_device_new_opencl '$T/exported' && ! grep -qx csi_fail '$T/exported' && ! grep -qx csi_recon '$T/exported'" "public exported, internal hidden"
while read -r sym; do
    grep -q "\b$sym(" "$S/host/include/csi/csi.h" "$S/host/include/csi/csi_opencl.h" || bad "exported but not declared in the public headers: $sym"
done < "$T/exported"

# find_package(csi): the examples build outside the tree
cmake -S "$S/examples/embed" -B "$T/ex" -DCMAKE_PREFIX_PATH="$T/prefix" -DCMAKE_BUILD_TYPE=Release > "$T/ex.log" 2>&1 &&
    cmake --build "$T/ex" >> "$T/ex.log" 2>&1
check "[[ $? == 0 && -x '$T/ex/reconstruct_dump' && -x '$T/ex/toy_render' ]]" "examples build: $(tail -5 "$T/ex.log")"
check "[[ \$(wc -l < '$S/examples/embed/reconstruct_dump.c') -lt 40 ]]" "reconstruct_dump.c is under 40 lines"

# the same bits: csi-render, csi-reconstruct on its dump, the embedded example on that dump
for sc in small_triangle small_moving; do
    "$B/csi-render" "$S/tests/cli/scenes/$sc.scene" -o "$T/$sc.r.exr" --dump "$T/$sc.csid" --stats "$T/$sc.r.json" -q
    "$B/csi-reconstruct" "$T/$sc.csid" -o "$T/$sc.c.exr" --stats "$T/$sc.c.json" -q
    "$T/ex/reconstruct_dump" "$T/$sc.csid" "$T/$sc.e.exr" "$T/$sc.e.json"
    check "[[ $? == 0 && -s '$T/$sc.e.exr' ]]" "$sc: the example reconstructs the dump"
    h1="$(json "$T/$sc.r.json" image_fnv1a64)"; h2="$(json "$T/$sc.c.json" image_fnv1a64)"
    h3="$(json "$T/$sc.e.json" image_fnv1a64)"
    check "[[ -n '$h1' && '$h1' == '$h2' && '$h2' == '$h3' ]]" "$sc: render $h1, reconstruct $h2, SDK example $h3"
done
"$T/ex/toy_render" "$T/toy.exr" 2 > "$T/toy.out" 2> "$T/toy.err"
check "[[ $? == 0 && -s '$T/toy.exr' ]] && grep -q '8 frames' '$T/toy.out'" "toy render loop: $(cat "$T/toy.out" "$T/toy.err" | tail -2)"

# pkg-config: the same example with the compiler alone
export PKG_CONFIG_PATH="$(dirname "$lib")/pkgconfig"
cc -std=c11 "$S/examples/embed/toy_render.c" $(pkg-config --cflags --libs csi) -lm -o "$T/toy_pc" 2> "$T/pc.log"
check "[[ $? == 0 ]]" "pkg-config build: $(head -3 "$T/pc.log")"
LD_LIBRARY_PATH="$(dirname "$lib")" "$T/toy_pc" "$T/toy2.exr" 2 > /dev/null 2>&1
check "[[ $? == 0 && -s '$T/toy2.exr' ]]" "pkg-config build runs"

finish
