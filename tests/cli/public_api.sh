#!/usr/bin/env bash
# The programs use csi.h only (issue 10). Every program's source and the program-support library
# (host/cli/common*.c) compile with the SDK's include directory alone (BUILD/sdk/include, the two
# public headers; csi-render adds its tracer's header): an internal header is not found there and
# a call of a function no public header declares is an error. And each program but csi-render is
# linked to libcsi.so, whose exports are the public API alone, and needs nothing else of csi's
# (csi-render links libcsi.a: its tracer shares base objects that libcsi.so keeps hidden).
# usage: public_api.sh BUILD_DIR SOURCE_DIR
set -u
B="$1"; S="$2"
pass=0; fail=0
ok()   { pass=$((pass + 1)); }
bad()  { fail=$((fail + 1)); echo "FAIL: $*" >&2; }
programs=(csi-mkdump csi-positions)
support=("$S"/host/cli/common.c "$S"/host/cli/common_eta.c "$S"/host/cli/common_files.c)

headers="$(cd "$B/sdk/include" && find . -type f | sort | tr '\n' ' ')"
[[ "$headers" == './csi/csi.h ./csi/csi_opencl.h ' ]] && ok || bad "sdk/include holds $headers"
flags=(-std=c11 -fsyntax-only -Werror=implicit-function-declaration -D_POSIX_C_SOURCE=200809L
       -DCSI_VERSION='"test"' -I "$B/sdk/include" -I "$S/host/cli")
for src in "${support[@]}"; do
    out="$(cc "${flags[@]}" "$src" 2>&1)" && ok || bad "$(basename "$src") needs more than csi.h: $(echo "$out" | grep -m2 error)"
done
nm -D --defined-only "$B/sdk/libcsi.so" | awk '{print $3}' | sort > "${TMPDIR:-/tmp}/csi_exports.$$"
for p in "${programs[@]}"; do
    src="$S/host/cli/${p//-/_}.c"
    out="$(cc "${flags[@]}" "$src" 2>&1)" && ok || bad "$p needs more than csi.h: $(echo "$out" | grep -m2 error)"
    readelf -d "$B/$p" | grep -q 'NEEDED.*\[libcsi\.so' && ok || bad "$p is not linked to libcsi.so"
    missing="$(nm -D --undefined-only "$B/$p" | awk '$2 ~ /^csi_/ {print $2}' | sort | comm -23 - "${TMPDIR:-/tmp}/csi_exports.$$")"
    [[ -z "$missing" ]] && ok || bad "$p needs csi symbols libcsi.so does not export: $missing"
done
rm -f "${TMPDIR:-/tmp}/csi_exports.$$"
echo "$pass passed, $fail failed"
[[ $fail == 0 ]]
