#!/usr/bin/env bash
# csi-mkdump end to end: converts committed PNGs (tests/data/io, made by tests/data/io/gen_refs.py
# with an independent PNG encoder) and checks the dumps byte by byte with od + awk against the
# expected linear values; then every bad input must exit 2 with a message and leave no file.
# Usage: bash mkdump.sh BUILD_DIR SOURCE_DIR
set -u
BUILD=$1
SRC=$2
MK="$BUILD/csi-mkdump"
DATA="$SRC/tests/data/io"
TMP=$(mktemp -d "${TMPDIR:-/tmp}/mkdump.XXXXXX")
trap 'rm -rf "$TMP"' EXIT
fails=0
pass=0
ok() { pass=$((pass + 1)); }
bad() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }

# header FILE: prints the 16 u32 words of the header on one line
header() { od -A n -v -t u4 -N 64 "$1" | tr -s ' \n' ' ' | sed 's/^ //'; }

# check_records FILE CHANNELS EXPECTED 3D: every record's values equal the expected value of its
# cell (relative 1e-6: od prints float32 with 8-9 digits, the table has %.9g); positions unique
# and sorted by linear index; prints the number of records checked.
check_records() {
    local f=$1 ch=$2 exp=$3 three=$4
    local rb=$((12 + 4 * ch))
    paste -d' ' <(od -A n -v -t u4 -w$rb -j 64 "$f") <(od -A n -v -t f4 -w$rb -j 64 "$f") |
        awk -v ch="$ch" -v nw=$((3 + ch)) -v three="$three" -v W="$5" -v H="$6" '
        NR == FNR { if (three) { key = $1 " " $2 " " $3; v[key] = $4 }
                    else { key = "0 " $1 " " $2; for (c = 0; c < 3; c++) v[key, c] = $(3 + c) }
                    next }
        {
            x = $1; y = $2; t = $3
            lin = (t * H + y) * W + x
            if (n > 0 && lin <= prev) { print "not sorted/unique at record " n > "/dev/stderr"; bad++ }
            prev = lin
            for (c = 0; c < ch; c++) {
                got = $(nw + 4 + c)
                want = three ? v[t " " x " " y] : v["0 " x " " y, c]
                d = got - want; if (d < 0) d = -d
                if (d > 1e-6 * (want < 0 ? -want : want) + 1e-9) {
                    print "record " n " (" x "," y "," t ") channel " c ": " got " vs " want > "/dev/stderr"; bad++
                }
            }
            n++
        }
        END { print n; exit bad > 0 }' "$exp" -
}

# --help
"$MK" --help | grep -q "usage: csi-mkdump" && ok || bad "--help"
[[ "$("$MK" --version)" == "csi-mkdump "* ]] && ok || bad "--version"

# 2-D, each method: header fields and values.
for m in stratified poisson random; do
    out="$TMP/rgb_$m.csid"
    "$MK" "$DATA/img_rgb.png" -o "$out" --out 4x3 --spp 4 --method $m --seed 5 -q || bad "$m: exit $?"
    # magic "CSID" = 1145656131 as u32 LE, version 1, 16 12 1 4 3, channels 3, count 48 (lo, hi),
    # seed 5 (lo, hi), reserved 0 x 4
    h=$(header "$out")
    [ "$h" = "1145656131 1 16 12 1 4 3 3 48 0 5 0 0 0 0 0 " ] && ok || bad "$m header: $h"
    [ "$(stat -c %s "$out")" = $((64 + 48 * 24)) ] && ok || bad "$m size"
    n=$(check_records "$out" 3 "$DATA/img_rgb.txt" 0 16 12) && [ "$n" = 48 ] && ok || bad "$m records ($n)"
done

# --exact: the header's flags (byte 48, the 13th u32) = 1, the records unchanged; the default 0.
"$MK" "$DATA/img_rgb.png" -o "$TMP/exact.csid" --out 4x3 --spp 4 --method stratified --seed 5 --exact -q ||
    bad "--exact: exit $?"
h=$(header "$TMP/exact.csid")
[ "$h" = "1145656131 1 16 12 1 4 3 3 48 0 5 0 1 0 0 0 " ] && ok || bad "--exact header: $h"
cmp -s <(tail -c +65 "$TMP/exact.csid") <(tail -c +65 "$TMP/rgb_stratified.csid") && ok || bad "--exact changed the records"

# Determinism and seeds.
"$MK" "$DATA/img_rgb.png" -o "$TMP/again.csid" --out 4x3 --spp 4 --seed 5 -q
cmp -s "$TMP/again.csid" "$TMP/rgb_poisson.csid" && ok || bad "same seed, same bytes"
"$MK" "$DATA/img_rgb.png" -o "$TMP/other.csid" --out 4x3 --spp 4 --seed 6 -q
cmp -s "$TMP/other.csid" "$TMP/rgb_poisson.csid" && bad "different seeds, same bytes" || ok

# --fraction: round(0.25 * 192) = 48 samples.
"$MK" "$DATA/img_rgb.png" -o "$TMP/frac.csid" --out 8x6 --fraction 0.25 --method random -q || bad "fraction"
h=$(header "$TMP/frac.csid")
[ "$(echo "$h" | cut -d' ' -f9)" = 48 ] && ok || bad "fraction count: $h"

# 3-D from frames: 8x8x4 grid, 4x4 output, 1 spp over all t (16 samples), and 25% (64).
"$MK" --frames "$DATA/frame_%03d.png" --count 4 -o "$TMP/vol.csid" --out 4x4 --spp 1 --method stratified -q ||
    bad "frames exit"
h=$(header "$TMP/vol.csid")
[ "$h" = "1145656131 1 8 8 4 4 4 1 16 0 1 0 0 0 0 0 " ] && ok || bad "frames header: $h"
n=$(check_records "$TMP/vol.csid" 1 "$DATA/frames.txt" 1 8 8) && [ "$n" = 16 ] && ok || bad "frames records ($n)"
"$MK" --frames "$DATA/frame_%03d.png" --count 4 -o "$TMP/vol2.csid" --out 2x2 --fraction 0.25 -q || bad "frames poisson"
n=$(check_records "$TMP/vol2.csid" 1 "$DATA/frames.txt" 1 8 8) && [ "$n" = 64 ] && ok || bad "frames poisson ($n)"
"$MK" --frames "$DATA/frame_%03d.png" --start 1 --count 3 -o "$TMP/vol3.csid" --out 4x4 -q || bad "--start"
[ "$(header "$TMP/vol3.csid" | cut -d' ' -f5)" = 3 ] && ok || bad "--start: grid_t"

# Bad input: exit 2, a one-line message naming the problem, no output file.
expect_bad() {
    local want=$1
    shift
    rm -f "$TMP/bad.csid"
    local err
    err=$("$MK" "$@" 2>&1 >/dev/null)
    local rc=$?
    if [ $rc -ne 2 ]; then bad "exit $rc for: $* ($err)"; return; fi
    if ! echo "$err" | grep -qF -- "$want"; then bad "message for: $* was '$err', wanted '$want'"; return; fi
    if [ "$(echo "$err" | wc -l)" -ne 1 ]; then bad "more than one line: $err"; return; fi
    if [ -e "$TMP/bad.csid" ]; then bad "output left behind for: $*"; return; fi
    ok
}
I="$DATA/img_rgb.png"
expect_bad "no output file" "$I" --out 4x3
expect_bad "no output size" "$I" -o "$TMP/bad.csid"
expect_bad "not a size" "$I" -o "$TMP/bad.csid" --out 4by3
expect_bad "not a multiple of --out 5x3" "$I" -o "$TMP/bad.csid" --out 5x3
expect_bad "only 192 cells" "$I" -o "$TMP/bad.csid" --out 4x3 --spp 17
expect_bad "not both" "$I" -o "$TMP/bad.csid" --out 4x3 --spp 2 --fraction 0.5
expect_bad "not a number in (0, 1]" "$I" -o "$TMP/bad.csid" --out 4x3 --fraction 1.5
expect_bad "not a positive integer" "$I" -o "$TMP/bad.csid" --out 4x3 --spp -3
expect_bad "unknown sampling method \"blue\"" "$I" -o "$TMP/bad.csid" --out 4x3 --method blue
expect_bad "unknown option --bogus" "$I" -o "$TMP/bad.csid" --out 4x3 --bogus
expect_bad "needs a value" "$I" -o "$TMP/bad.csid" --out
expect_bad "nope.png: cannot open" "$TMP/nope.png" -o "$TMP/bad.csid" --out 4x3
expect_bad "neither a PNG nor an EXR" "$DATA/img_rgb.txt" -o "$TMP/bad.csid" --out 4x3
expect_bad "does not exist" "$I" -o "$TMP/no/dir/bad.csid" --out 4x3
expect_bad "exactly one integer conversion" --frames "$DATA/frame_%s.png" --count 4 -o "$TMP/bad.csid" --out 4x4
expect_bad "a width of at most 20" --frames "$DATA/frame_%999999d.png" --count 4 -o "$TMP/bad.csid" --out 4x4
expect_bad "--count T with T >= 2" --frames "$DATA/frame_%03d.png" -o "$TMP/bad.csid" --out 4x4
expect_bad "frame_004.png: cannot open" --frames "$DATA/frame_%03d.png" --count 5 -o "$TMP/bad.csid" --out 4x4
cp "$DATA/img_rgb.png" "$TMP/mix_001.png"
cp "$DATA/frame_000.png" "$TMP/mix_000.png"
expect_bad "frame 1 is 16x12" --frames "$TMP/mix_%03d.png" --count 2 -o "$TMP/bad.csid" --out 4x4
# A truncated PNG.
head -c 100 "$I" > "$TMP/cut.png"
expect_bad "cut.png" "$TMP/cut.png" -o "$TMP/bad.csid" --out 4x3

echo "$pass passed, $fails failed"
[ $fails -eq 0 ]
