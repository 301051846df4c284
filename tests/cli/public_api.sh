#!/usr/bin/env bash
# The programs use csi.h only (issue 10). Every program's main and the program-support library
# csi_cli (host/cli/common*.c) compile with the SDK's include directory alone
# (BUILD/sdk/include, the two public headers, and host/cli; csi-render adds its tracer's header,
# which needs csi.h only): an internal header is not found there, and a call of a function no
# public header declares is an error. That includes the --tile runs and csi-merge, which write and
# read tile partials through csi.h. csi-mkdump, csi-positions and csi-merge are linked to
# libcsi.so, whose exports are the public API alone, and need nothing else of csi's. No C file of
# host/cli is an exception, and none may include a header of the library's source tree.
# usage: public_api.sh BUILD_DIR SOURCE_DIR
set -u
B="$1"; S="$2"
pass=0; fail=0
ok()   { pass=$((pass + 1)); }
bad()  { fail=$((fail + 1)); echo "FAIL: $*" >&2; }
mains=(csi-mkdump csi-positions csi-reconstruct csi-render csi-merge)
shared=(csi-mkdump csi-positions csi-merge)

headers="$(cd "$B/sdk/include" && find . -type f | sort | tr '\n' ' ')"
[[ "$headers" == './csi/csi.h ./csi/csi_opencl.h ' ]] && ok || bad "sdk/include holds $headers"
flags=(-std=c11 -fsyntax-only -Werror=implicit-function-declaration -D_POSIX_C_SOURCE=200809L
       -DCSI_VERSION='"test"' -I "$B/sdk/include" -I "$S/host/cli")
# Every C file of host/cli is checked here: the mains, csi_cli (common*.c, the tile runs too).
for src in "$S"/host/cli/*.c; do
    f="$(basename "$src")"
    extra=()
    [[ "$f" == csi_render.c ]] && extra=(-I "$S/tracer")
    out="$(cc "${flags[@]}" "${extra[@]}" "$src" 2>&1)" && ok || bad "$f needs more than csi.h: $(echo "$out" | grep -m2 error)"
done
for p in "${mains[@]}"; do
    [[ -f "$S/host/cli/${p//-/_}.c" ]] && ok || bad "$p has no source ${p//-/_}.c"
done
# Nor by a relative path into the library's sources, which -I would not stop.
for src in "$S"/host/cli/*.[ch]; do
    ! grep -Eq '#include "\.\./' "$src" && ok || bad "$(basename "$src") includes a file of the library's sources"
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
