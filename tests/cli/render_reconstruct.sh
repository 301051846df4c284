#!/usr/bin/env bash
# Command-line behaviour of csi-render and csi-reconstruct: help, plans, the dump contract
# (csi-reconstruct on csi-render's --dump gives the same pixels, bit for bit), determinism, and
# bad input (exit code 2, one line on stderr naming the file and the problem, no output left).
# usage: render_reconstruct.sh BUILD_DIR SOURCE_DIR
set -u
B="$1"; S="$2"
source "$(dirname "${BASH_SOURCE[0]}")/../support/testlib.sh"
static="$S/tests/cli/scenes/small_triangle.scene"
moving="$S/tests/cli/scenes/small_moving.scene"
fast=(--max-iter 40 -q)

# --- help and version --------------------------------------------------------------------------
for p in csi-render csi-reconstruct; do
    "$B/$p" --help > "$T/help" 2>&1; check "[[ $? == 0 ]] && grep -q usage '$T/help'" "$p --help"
    "$B/$p" --version > "$T/ver" 2>&1; check "[[ $? == 0 ]] && grep -q '$p' '$T/ver'" "$p --version"
    # every option's text whole, to its closing "[default: ...]" (a fixed buffer once cut one off)
    cut=$(awk '/^      --|^  -|^[a-z]/ { if (blk ~ /\[default:/ && blk !~ /\][ ]*$/) print name; blk = ""; name = $1 }
               { blk = blk " " $0 } END { if (blk ~ /\[default:/ && blk !~ /\][ ]*$/) print name }' "$T/help")
    check "[[ -z '$cut' ]]" "$p --help: the text of $cut is cut short"
done

# --- the plan: only what the scene calls for -------------------------------------------------
"$B/csi-render" --plan "$static" > "$T/plan_s.json"
check "grep -q '\"frames\": 1,' '$T/plan_s.json' && grep -q '\"rays_carry_time\": false' '$T/plan_s.json' && grep -q '\"method\": \"2d-antialias\"' '$T/plan_s.json'" "static plan: $(cat "$T/plan_s.json")"
"$B/csi-render" --plan "$moving" > "$T/plan_m.json"
check "grep -q '\"frames\": 8,' '$T/plan_m.json' && grep -q '\"rays_carry_time\": true' '$T/plan_m.json' && grep -q '\"method\": \"3d-motion\"' '$T/plan_m.json'" "moving plan: $(cat "$T/plan_m.json")"

# --- render, dump, reconstruct: same pixels --------------------------------------------------
for sc in static moving; do
    scene="${!sc}"
    "$B/csi-render" "$scene" -o "$T/$sc.exr" --png "$T/$sc.png" --dump "$T/$sc.csid" --stats "$T/$sc.r.json" "${fast[@]}"
    check "[[ $? == 0 && -s '$T/$sc.exr' && -s '$T/$sc.png' && -s '$T/$sc.csid' ]]" "$sc render outputs"
    "$B/csi-reconstruct" "$T/$sc.csid" -o "$T/$sc.2.exr" --stats "$T/$sc.c.json" "${fast[@]}"
    check "[[ $? == 0 && -s '$T/$sc.2.exr' ]]" "$sc reconstruct outputs"
    h1="$(json "$T/$sc.r.json" image_fnv1a64)"; h2="$(json "$T/$sc.c.json" image_fnv1a64)"
    check "[[ -n '$h1' && '$h1' == '$h2' ]]" "$sc: csi-render and csi-reconstruct pixels differ ($h1 vs $h2)"
    "$B/csi-render" "$scene" -o "$T/$sc.3.exr" --stats "$T/$sc.r3.json" "${fast[@]}"
    h3="$(json "$T/$sc.r3.json" image_fnv1a64)"
    check "[[ '$h1' == '$h3' ]]" "$sc: two runs with the same seed differ"
    "$B/csi-render" "$scene" -o "$T/$sc.4.exr" --stats "$T/$sc.r4.json" --seed 7 "${fast[@]}"
    h4="$(json "$T/$sc.r4.json" image_fnv1a64)"
    check "[[ '$h1' != '$h4' ]]" "$sc: another seed gives the same image"
done
# what the samples are (docs/dump-format.md, byte 48): a scene without random effects gives exact
# values, flagged in the dump, and --correct auto resolves to cv in both programs; ambient
# occlusion makes them Monte Carlo estimates: not flagged, the blend; the same pixels either way
check "grep -q '\"exact\": true' '$T/plan_s.json'" "static plan not exact: $(cat "$T/plan_s.json")"
for f in static.r static.c; do
    check "[[ '$(json "$T/$f.json" correct)' == cv ]]" "$f.json: correct $(json "$T/$f.json" correct), not cv"
done
check "[[ \"\$(od -An -tu4 -j48 -N4 '$T/static.csid' | tr -d ' ')\" == 1 ]]" "static dump: flags not 1"
sed 's/^background 0 0 0$/background 0 0 0\nambient_occlusion { samples 2 distance 1 color 0.5 0.5 0.5 }/' \
    "$static" > "$T/ao.scene"
"$B/csi-render" --plan "$T/ao.scene" > "$T/plan_ao.json"
check "grep -q '\"exact\": false' '$T/plan_ao.json' && grep -q '\"ambient_occlusion\": {' '$T/plan_ao.json'" "AO plan: $(cat "$T/plan_ao.json")"
"$B/csi-render" "$T/ao.scene" -o "$T/ao.exr" --dump "$T/ao.csid" --stats "$T/ao.r.json" "${fast[@]}"
"$B/csi-reconstruct" "$T/ao.csid" -o "$T/ao.2.exr" --stats "$T/ao.c.json" "${fast[@]}"
check "[[ \"\$(od -An -tu4 -j48 -N4 '$T/ao.csid' | tr -d ' ')\" == 0 ]]" "AO dump flagged exact"
for f in ao.r ao.c; do
    check "[[ '$(json "$T/$f.json" correct)' == blend ]]" "$f.json: correct $(json "$T/$f.json" correct), not blend"
done
h1="$(json "$T/ao.r.json" image_fnv1a64)"; h2="$(json "$T/ao.c.json" image_fnv1a64)"
check "[[ -n '$h1' && '$h1' == '$h2' ]]" "AO: csi-render and csi-reconstruct pixels differ ($h1 vs $h2)"
# the stats give every phase's time, per channel for the solves (issue 13)
for f in static.r static.c moving.c; do
    check "grep -q '\"phases\": {' '$T/$f.json' && grep -q '\"read_s\": ' '$T/$f.json' && grep -q '\"write_s\": ' '$T/$f.json' && grep -q '\"fixed_s\": ' '$T/$f.json' && grep -q '\"per_sample_us\": ' '$T/$f.json'" "$f.json: phases missing"
    check "sed -n '/\"solve_s\": {/,/}/p' '$T/$f.json' | grep -q '\"2\": '" "$f.json: no solve time of the third channel"
done
# the cross-validated choice's folds (noisy samples: the AO dump) are a phase of their own, with
# the pixels it gave their mean; exact samples (static) take no folds and report none
check "[[ '$(json "$T/ao.c.json" cv_select)' == on ]]" "ao.c.json: cv_select $(json "$T/ao.c.json" cv_select), not on"
check "grep -q '\"cross_validation_s\": ' '$T/ao.c.json' && grep -q '\"cv_switched_pixels\": ' '$T/ao.c.json'" "ao.c.json: no cross-validation phase"
check "! grep -q '\"cross_validation_s\"\\|\"cv_switched_pixels\"' '$T/static.c.json'" "static.c.json: a cross-validation phase without folds"
# static scenes trace no time; moving ones do
check "grep -q '\"timed\": 0,' '$T/static.r.json'" "static render traced rays with time"
check "! grep -q '\"timed\": 0,' '$T/moving.r.json'" "moving render traced no rays with time"
# the folder named as README.md names it, with a slash after it (once refused after the solve)
"$B/csi-render" "$moving" -o "$T/mf.exr" --frames "$T/frames/" "${fast[@]}"
check "[[ -s '$T/frames/frame_0000.exr' && -s '$T/frames/frame_0007.png' && ! -e '$T/frames/frame_0008.exr' ]]" "frames written"
for m in stratified random; do
    "$B/csi-render" "$static" --method $m -o "$T/$m.exr" --stats "$T/$m.json" -q
    check "[[ $? == 0 ]] && grep -q '\"estimator\": \"mean\"' '$T/$m.json'" "--method $m"
    check "[[ '$(json "$T/$m.json" cell_point)' == jittered ]]" "--method $m: cell_point $(json "$T/$m.json" cell_point), not jittered"
done
# where a sample lies in its cell: the compressive method at the centres by default, the same bits
# as --cell-point centre; jittered, other pixels; Monte Carlo at the centres differs from its default
check "[[ '$(json "$T/static.r.json" cell_point)' == centre ]]" "cs: cell_point $(json "$T/static.r.json" cell_point), not centre"
"$B/csi-render" "$static" --cell-point centre -o "$T/cc.exr" --stats "$T/cc.json" "${fast[@]}"
"$B/csi-render" "$static" --cell-point jittered -o "$T/cj.exr" --stats "$T/cj.json" "${fast[@]}"
check "[[ '$(json "$T/cc.json" image_fnv1a64)' == '$(json "$T/static.r.json" image_fnv1a64)' ]]" "cs --cell-point centre is not the default"
check "[[ '$(json "$T/cj.json" image_fnv1a64)' != '$(json "$T/cc.json" image_fnv1a64)' && '$(json "$T/cj.json" cell_point)' == jittered ]]" "cs --cell-point jittered: the centres' image"
"$B/csi-render" "$static" --method stratified --cell-point centre -o "$T/mc.exr" --stats "$T/mc.json" -q
check "[[ '$(json "$T/mc.json" image_fnv1a64)' != '$(json "$T/stratified.json" image_fnv1a64)' ]]" "stratified --cell-point centre: the jittered image"

# references: SPP distinct stratified samples per pixel, moving scenes included (x, y and t)
for sc in static moving; do
    scene="${!sc}"
    "$B/csi-render" "$scene" --reference 64 -o "$T/$sc.ref.exr" --stats "$T/$sc.ref.json" -q
    check "[[ $? == 0 ]] && grep -q '\"samples\": 65536,' '$T/$sc.ref.json'" "$sc --reference 64"
done

# --- bad input: exit 2, one line naming the problem, no output file --------------------------
expect_fail "--cell-point" "--cell-point: 'middle'" "$B/csi-render" "$static" --cell-point middle -o "$T/out.exr"
good="$T/static.csid"
expect_fail "missing dump" "nonexistent.csid" "$B/csi-reconstruct" "$T/nonexistent.csid" -o "$T/out.exr"
printf 'XXXX' | cat - <(tail -c +5 "$good") > "$T/magic.csid"
expect_fail "wrong magic" "magic.csid" "$B/csi-reconstruct" "$T/magic.csid" -o "$T/out.exr"
head -c 100 "$good" > "$T/trunc.csid"
expect_fail "truncated" "trunc.csid" "$B/csi-reconstruct" "$T/trunc.csid" -o "$T/out.exr"
head -c 40 "$good" > "$T/header.csid"
expect_fail "truncated header" "header.csid" "$B/csi-reconstruct" "$T/header.csid" -o "$T/out.exr"
cp "$good" "$T/nan.csid"; printf '\x00\x00\xc0\x7f' | dd of="$T/nan.csid" bs=1 seek=76 conv=notrunc 2>/dev/null
expect_fail "NaN sample" "NaN" "$B/csi-reconstruct" "$T/nan.csid" -o "$T/out.exr"
"$B/csi-reconstruct" "$T/nan.csid" -o "$T/out.exr" --drop-invalid "${fast[@]}"
check "[[ $? == 0 && -s '$T/out.exr' ]]" "--drop-invalid reconstructs without the NaN record"
cp "$good" "$T/ver.csid"; printf '\x09' | dd of="$T/ver.csid" bs=1 seek=4 conv=notrunc 2>/dev/null
expect_fail "unknown version" "version" "$B/csi-reconstruct" "$T/ver.csid" -o "$T/out.exr"
cp "$good" "$T/pos.csid"; printf '\xff\xff\x00\x00' | dd of="$T/pos.csid" bs=1 seek=64 conv=notrunc 2>/dev/null
expect_fail "position outside the grid" "pos.csid" "$B/csi-reconstruct" "$T/pos.csid" -o "$T/out.exr"
expect_fail "unwritable output" "no-such-dir" "$B/csi-reconstruct" "$good" -o "$T/no-such-dir/out.exr"
expect_fail "unknown option" "--bogus" "$B/csi-reconstruct" "$good" -o "$T/out.exr" --bogus
expect_fail "bad number" "--lambda" "$B/csi-reconstruct" "$good" -o "$T/out.exr" --lambda abc
# a negative seed: the range said (it was 'is not a whole number')
expect_fail "negative seed" "from 0 to 2^64 - 1" "$B/csi-reconstruct" "$good" -o "$T/out.exr" --seed -1
expect_fail "render: negative seed" "from 0 to 2^64 - 1" "$B/csi-render" "$static" -o "$T/out.exr" --seed -1
expect_fail "no output" "no output" "$B/csi-reconstruct" "$good"
expect_fail "romp on a volume" "ROMP" "$B/csi-reconstruct" "$T/moving.csid" -o "$T/out.exr" --solver romp
CSI_DEVICE=no-such-device expect_fail "missing OpenCL device" "no OpenCL device matches" \
    "$B/csi-reconstruct" "$good" -o "$T/out.exr"
# --cache-programs: no input beside it; refused with the cache off
expect_fail "cache-programs with an input" "takes no input" "$B/csi-reconstruct" --cache-programs "$good"
CSI_PROGRAM_CACHE=0 expect_fail "cache-programs, cache off" "program cache is off" \
    "$B/csi-reconstruct" --cache-programs
expect_fail "render --cache-programs with a scene" "takes no scene" "$B/csi-render" --cache-programs "$static"
CSI_PROGRAM_CACHE=0 expect_fail "render --cache-programs, cache off" "program cache is off" \
    "$B/csi-render" --cache-programs
# a cache folder that cannot be made (under a file): named as such, where PoCL alone would fail to
# start and the program would say that no device was found
CSI_CACHE_DIR="$good/cache" expect_fail "cache folder not writable" "cannot keep kernel caches in $good/cache/" \
    "$B/csi-reconstruct" "$good" -o "$T/out.exr"
# settings the library reads from the environment: a value they cannot mean is refused, not read
# as another (CSI_HOST_THREADS=abc ran on one thread, =-3 too; CSI_PROGRAM_CACHE=no kept it on)
for setting in CSI_HOST_THREADS=abc CSI_HOST_THREADS=-3 CSI_HOST_THREADS=0 CSI_PROGRAM_CACHE=no \
               CSI_HOST_MEMORY_LIMIT=2G; do
    export "$setting"
    expect_fail "$setting" "$setting is" "$B/csi-reconstruct" "$good" -o "$T/out.exr"
    unset "${setting%%=*}"
done
CSI_HOST_THREADS=abc expect_fail "render: CSI_HOST_THREADS=abc" "CSI_HOST_THREADS=abc is" \
    "$B/csi-render" "$static" -o "$T/out.exr"
printf 'camera { position 0 0 -2 target 0 0 0 up 0 1 0 fov 40 size 8 8 }\nbogus 1 2 3\n' > "$T/bad.scene"
expect_fail "scene error" "bad.scene:2:1" "$B/csi-render" "$T/bad.scene" -o "$T/out.exr"
expect_fail "missing scene" "nothere.scene" "$B/csi-render" "$T/nothere.scene" -o "$T/out.exr"
expect_fail "grid not a multiple" "--grid" "$B/csi-render" "$static" -o "$T/out.exr" --grid 50
CSI_DEVICE=no-such-device expect_fail "render without device" "no OpenCL device matches" \
    "$B/csi-render" "$static" -o "$T/out.exr"

finish
