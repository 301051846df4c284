#!/usr/bin/env bash
# csi-positions: the positions request (docs/dump-format.md, channels = 0) holds exactly the
# grid and positions csi-render samples for the same size, spp and seed (static and moving), the
# default grid follows csi-render's rule, csi-reconstruct refuses a request with a clear line,
# and bad input exits 2 with one line and no file left behind.
# usage: positions.sh BUILD_DIR SOURCE_DIR
set -u
B="$1"; S="$2"
source "$(dirname "${BASH_SOURCE[0]}")/../support/testlib.sh"

P="$B/csi-positions"
"$P" --help > "$T/help" 2>&1; check "[[ $? == 0 ]] && grep -q usage '$T/help'" "--help"
"$P" --version > "$T/ver" 2>&1; check "[[ $? == 0 ]] && grep -q csi-positions '$T/ver'" "--version"

# --- the same positions as csi-render: static (default grid 8x at 4 spp), moving (2x from one
# sample per 8 frames, T = 8) --
static="$S/tests/cli/scenes/small_triangle.scene"
moving="$S/tests/cli/scenes/small_moving.scene"
for spp in 1 4 16; do
    "$B/csi-render" "$static" --spp $spp --seed 3 --dump "$T/r$spp.csid" -o "$T/r.exr" --max-iter 5 -q
    "$P" --out 32x32 --spp $spp --seed 3 -o "$T/q$spp.csid" -q
    check "[[ $? == 0 ]]" "static $spp spp: csi-positions failed"
    # default grid: 4x to 3 spp, 8x for 4-15, 16x from 16 (csi_default_grid_factor)
    f=$(( spp < 4 ? 4 : spp < 16 ? 8 : 16 ))
    n=$(( spp * 32 * 32 ))
    check "[[ '$(dump_hdr "$T/q$spp.csid")' == '$((32 * f)) $((32 * f)) 1 32 32 0 $n' ]]" \
          "static $spp spp header: $(dump_hdr "$T/q$spp.csid")"
    check "[[ '$(dump_hdr "$T/r$spp.csid")' == '$((32 * f)) $((32 * f)) 1 32 32 3 $n' ]]" \
          "csi-render's dump header at $spp spp: $(dump_hdr "$T/r$spp.csid")"
    check "[[ \$(stat -c %s '$T/q$spp.csid') == $((64 + 12 * n)) ]]" "request size at $spp spp"
    check "cmp -s <(dump_xyt '$T/q$spp.csid' 12) <(dump_xyt '$T/r$spp.csid' 24)" "static $spp spp: positions differ from csi-render's"
done
"$B/csi-render" "$moving" --spp 2 --seed 5 --dump "$T/rm.csid" -o "$T/r.exr" --max-iter 5 -q
"$P" --out 32x32 --spp 2 --seed 5 --time-steps 8 -o "$T/qm.csid" -q
check "[[ '$(dump_hdr "$T/qm.csid")' == '64 64 8 32 32 0 2048' ]]" "moving header: $(dump_hdr "$T/qm.csid")"
# fewer than one sample per 8 frames: the pixel grid (1 spp over 16 frames)
"$P" --out 32x32 --spp 1 --seed 5 --time-steps 16 -o "$T/qm1.csid" -q
check "[[ '$(dump_hdr "$T/qm1.csid")' == '32 32 16 32 32 0 1024' ]]" "moving header at 1 spp, 16 frames: $(dump_hdr "$T/qm1.csid")"
# from one sample per 8 frames 2 x 2 cells a pixel, 3 x 3 from 9 spp, 4 x 4 from 16
for sf in 8:2 9:3 15:3 16:4 64:4; do
    spp=${sf%:*}; f=${sf#*:}
    "$P" --out 32x32 --spp $spp --seed 5 --time-steps 8 -o "$T/qf.csid" -q
    check "[[ '$(dump_hdr "$T/qf.csid")' == '$((32 * f)) $((32 * f)) 8 32 32 0 $((spp * 1024))' ]]" \
          "moving header at $spp spp, 8 frames: $(dump_hdr "$T/qf.csid")"
done
# a moving camera keeps csi-render on the pixel grid (its plan knows; csi-positions does not),
# except one translating across its view, which takes a still camera's (2 x 2 cells from one
# sample per 8 frames: 1 spp at 8 frames)
sed 's/fov 40 size 32 32 }/fov 40 size 32 32 motion { key 0 { translate 0 0 0 } key 1 { translate 0.2 0 0 } } }/' \
    "$moving" > "$T/camera_pans.scene"
sed 's/fov 40 size 32 32 }/fov 40 size 32 32 motion { key 0 { translate 0 0 0 } key 1 { translate 0 0 0 rotate 0 1 0 8 } } }/' \
    "$moving" > "$T/camera_turns.scene"
for c in "pans 1 64" "pans 4 64" "turns 4 32"; do
    set -- $c
    "$B/csi-render" "$T/camera_$1.scene" --spp $2 --seed 5 --dump "$T/rc.csid" -o "$T/r.exr" --max-iter 5 -q
    check "[[ '$(dump_hdr "$T/rc.csid")' == '$3 $3 8 32 32 3 $(( $2 * 1024 ))' ]]" \
          "a camera that $1, $2 spp: grid $(dump_hdr "$T/rc.csid")"
done
check "cmp -s <(dump_xyt '$T/qm.csid' 12) <(dump_xyt '$T/rm.csid' 24)" "moving: positions differ from csi-render's"
# the default on a volume from 2 spp is stratified over each pixel's shutter; csi-render
# --positions asks for another, as csi-positions --method does
"$P" --out 32x32 --spp 2 --seed 5 --time-steps 8 --method stratified -o "$T/qms.csid" -q
check "cmp -s '$T/qm.csid' '$T/qms.csid'" "moving at 2 spp: the default is not stratified"
"$B/csi-render" "$moving" --spp 2 --seed 5 --positions poisson --dump "$T/rmp.csid" -o "$T/r.exr" --max-iter 5 -q
"$P" --out 32x32 --spp 2 --seed 5 --time-steps 8 --method poisson -o "$T/qmp.csid" -q
check "cmp -s <(dump_xyt '$T/qmp.csid' 12) <(dump_xyt '$T/rmp.csid' 24)" "--positions poisson: positions differ from csi-positions'"
check "! cmp -s '$T/qmp.csid' '$T/qm.csid'" "--positions poisson gives the default's positions"
expect_fail "csi-render: unknown positions" "--positions" "$B/csi-render" "$moving" --positions sobol -o "$T/out.exr"
expect_fail "csi-render: positions with a Monte Carlo method" "--method stratified samples its own" \
    "$B/csi-render" "$moving" --positions poisson --method stratified -o "$T/out.exr"
"$P" --out 32x32 --spp 2 --seed 6 --time-steps 8 -o "$T/qm6.csid" -q
check "! cmp -s '$T/qm.csid' '$T/qm6.csid'" "another seed gives the same positions"
for m in stratified random; do
    "$B/csi-render" "$static" --spp 4 --method $m --dump "$T/r$m.csid" -o "$T/r.exr" -q
    "$P" --out 32x32 --spp 4 --method $m -o "$T/q$m.csid" -q
    check "cmp -s <(dump_xyt '$T/q$m.csid' 12) <(dump_xyt '$T/r$m.csid' 24)" "--method $m: positions differ from csi-render's"
done
"$P" --out 32x16 --spp 2 --grid 64 -o "$T/g.csid" -q
check "[[ '$(dump_hdr "$T/g.csid")' == '64 32 1 32 16 0 1024' ]]" "--grid 64 on 32x16: $(dump_hdr "$T/g.csid")"
"$P" --out 32x32 --fraction 0.25 --grid 64 -o "$T/f.csid" -q
check "[[ '$(dump_hdr "$T/f.csid")' == '64 64 1 32 32 0 1024' ]]" "--fraction 0.25: $(dump_hdr "$T/f.csid")"

# --- progress where stderr is a log: plain lines while the Poisson-disk passes run (4 M cells, more
# candidates than one report interval), the same request as a quiet run's ---------------------------
CSI_PROGRESS=0 "$P" --out 256x256 --spp 4 -o "$T/big.csid" 2> "$T/big.err"
check "[[ $? == 0 ]] && [[ $(grep -c '^csi-positions: progress: positions [0-9]*%  [0-9]* / 262144 placed' "$T/big.err") -ge 2 ]]" \
    "progress lines: $(head -3 "$T/big.err")"
"$P" --out 256x256 --spp 4 -o "$T/bigq.csid" -q 2> "$T/bigq.err"
check "[[ ! -s '$T/bigq.err' ]] && cmp -s '$T/big.csid' '$T/bigq.csid'" "quiet: $(head -2 "$T/bigq.err")"

# --- bad input: exit 2, one line naming the problem, nothing written ---------------------------
expect_fail "request is not samples" "positions request" "$B/csi-reconstruct" "$T/q4.csid" -o "$T/out.exr"
expect_fail "no output" "-o" "$P" --out 32x32
expect_fail "no size" "--out" "$P" -o "$T/out.csid"
expect_fail "bad size" "--out" "$P" --out 32x0 -o "$T/out.csid"
expect_fail "grid not a multiple" "--grid" "$P" --out 32x32 --grid 50 -o "$T/out.csid"
expect_fail "more samples than cells" "cells" "$P" --out 32x32 --grid 32 --spp 2 -o "$T/out.csid"
expect_fail "unknown method" "poisson" "$P" --out 32x32 --method sobol -o "$T/out.csid"
expect_fail "bad fraction" "--fraction" "$P" --out 32x32 --fraction 1.5 -o "$T/out.csid"
expect_fail "negative seed" "from 0 to 2^64 - 1" "$P" --out 32x32 --seed -1 -o "$T/out.csid"
expect_fail "unwritable output" "no-such-dir" "$P" --out 32x32 -o "$T/no-such-dir/out.csid"
# the output stated before work, as every program's (it was: 'write failed' after the positions)
mkdir "$T/sub"
expect_fail "a directory as the output" "is a directory" "$P" --out 32x32 -o "$T/sub"
expect_fail "'.' as the output" "is a directory" "$P" --out 32x32 -o "$T/sub/."
# written whole or not at all: a failure of its write, or of its rename into place, leaves nothing
for n in 1 2; do
    CSI_FAIL_OUTPUT=$n "$P" --out 32x32 -o "$T/sub/r.csid" -q 2> /dev/null
    check "[[ $? == 2 && -z \"\$(ls -A '$T/sub')\" ]]" "output event $n failing left: $(ls -A "$T/sub")"
done
expect_fail "stray argument" "stray" "$P" --out 32x32 -o "$T/out.csid" stray
expect_fail "unknown option" "--bogus" "$P" --out 32x32 -o "$T/out.csid" --bogus

finish
