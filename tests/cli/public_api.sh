#!/usr/bin/env bash
# The programs use csi.h only (issue 10). Every program's main and the program-support library
# csi_cli (host/cli/common*.c but the tile runs) compile with the SDK's include directory alone
# (BUILD/sdk/include, the two public headers, and host/cli; csi-render adds its tracer's header,
# which needs csi.h only): an internal header is not found there, and a call of a function no
# public header declares is an error. csi-mkdump and csi-positions are linked to libcsi.so, whose
# exports are the public API alone, and need nothing else of csi's. The exceptions, named here so
# that they stay few: the --tile runs (host/cli/common_tile_run.c, common_partial.c) and csi-merge
# read and write tile partials, which hold the library's own tile layout (host/cli/tile.h says
# why), so they include internal headers, and csi-reconstruct and csi-render link the static
# library for them.
# usage: public_api.sh BUILD_DIR SOURCE_DIR
set -u
B="$1"; S="$2"
pass=0; fail=0
ok()   { pass=$((pass + 1)); }
bad()  { fail=$((fail + 1)); echo "FAIL: $*" >&2; }
mains=(csi-mkdump csi-positions csi-reconstruct csi-render)
shared=(csi-mkdump csi-positions)
internal=(common_tile_run.c common_partial.c csi_merge.c)

headers="$(cd "$B/sdk/include" && find . -type f | sort | tr '\n' ' ')"
[[ "$headers" == './csi/csi.h ./csi/csi_opencl.h ' ]] && ok || bad "sdk/include holds $headers"
flags=(-std=c11 -fsyntax-only -Werror=implicit-function-declaration -D_POSIX_C_SOURCE=200809L
       -DCSI_VERSION='"test"' -I "$B/sdk/include" -I "$S/host/cli")
# Every C file of host/cli is either checked here or one of the named exceptions.
for src in "$S"/host/cli/*.c; do
    f="$(basename "$src")"
    [[ " ${internal[*]} " == *" $f "* ]] && continue
    extra=()
    [[ "$f" == csi_render.c ]] && extra=(-I "$S/tracer")
    out="$(cc "${flags[@]}" "${extra[@]}" "$src" 2>&1)" && ok || bad "$f needs more than csi.h: $(echo "$out" | grep -m2 error)"
done
for p in "${mains[@]}"; do
    [[ -f "$S/host/cli/${p//-/_}.c" ]] && ok || bad "$p has no source ${p//-/_}.c"
done
# The exceptions do include internal headers (else they belong above).
for f in "${internal[@]}"; do
    grep -Eq '#include "(\.\./api/|csi/(tiles|stats|reconstruct|outfile|positions)\.h)' "$S/host/cli/$f" \
        && ok || bad "$f includes no internal header: check it with the others"
done
nm -D --defined-only "$B/sdk/libcsi.so" | awk '{print $3}' | sort > "${TMPDIR:-/tmp}/csi_exports.$$"
for p in "${shared[@]}"; do
    readelf -d "$B/$p" | grep -q 'NEEDED.*\[libcsi\.so' && ok || bad "$p is not linked to libcsi.so"
    missing="$(nm -D --undefined-only "$B/$p" | awk '$2 ~ /^csi_/ {print $2}' | sort | comm -23 - "${TMPDIR:-/tmp}/csi_exports.$$")"
    [[ -z "$missing" ]] && ok || bad "$p needs csi symbols libcsi.so does not export: $missing"
done
rm -f "${TMPDIR:-/tmp}/csi_exports.$$"
echo "$pass passed, $fail failed"
[[ $fail == 0 ]]
