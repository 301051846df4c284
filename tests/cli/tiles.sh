#!/usr/bin/env bash
# Tiles on the command line (docs/tiles.md): a run tiled in one process, the same tiles run one
# by one with --tile I/N (in any order, the scale given or computed; noisy samples too, with the
# cross-validated choice in each tile) and blended by csi-merge,
# and csi-render tracing only each tile's samples, all give the same pixels, bit for bit (image
# hashes in the statistics, frame PNGs byte for byte; csi-reconstruct's EXR and the merge's byte
# for byte, attributes too), also for an image and a volume whose side or frame count the FFT
# cannot take (solved padded, or in tiles of its own grid); csi-merge refuses a missing, repeated,
# foreign (another dump, scene, options or layout), truncated, damaged, other-version or
# non-partial input, and a layout csi does not make, with one line naming the file, exit 2 and
# no output.
# usage: tiles.sh BUILD_DIR SOURCE_DIR
set -u
B="$1"; S="$2"
source "$(dirname "${BASH_SOURCE[0]}")/../support/testlib.sh"
static="$S/tests/cli/scenes/small_triangle.scene"
moving="$S/tests/cli/scenes/small_moving.scene"
# 32x32 pixels: 4-pixel margins (2 frames in t) let a 32-pixel image hold several tiles
tiles=(--tile-margin 4 --tile-margin-t 2 --max-iter 40 -q)

# --- static: one process, tile by tile, csi-render tile by tile --------------------------------
"$B/csi-render" "$static" --dump "$T/s.csid" -o "$T/s.exr" --stats "$T/s.json" --tiles 4 "${tiles[@]}"
check "[[ $? == 0 ]] && grep -q '\"tiles\": 4,' '$T/s.json'" "csi-render --tiles 4"
ha="$(json "$T/s.json" image_fnv1a64)"
"$B/csi-reconstruct" "$T/s.csid" -o "$T/s2.exr" --stats "$T/s2.json" --tiles 4 "${tiles[@]}"
check "[[ '$(json "$T/s2.json" image_fnv1a64)' == '$ha' ]]" "csi-reconstruct --tiles 4 differs from csi-render's"
"$B/csi-reconstruct" "$T/s.csid" --tiles 4 --tile-info "${tiles[@]}" > "$T/info.json"
check "[[ $? == 0 ]] && grep -q '\"tiles\": 4,' '$T/info.json'" "--tile-info: $(cat "$T/info.json")"
scale="$(json_text "$T/info.json" tile_scale)"
check "[[ -n '$scale' ]]" "--tile-info gives the scale"
for i in 3 1; do
    "$B/csi-reconstruct" "$T/s.csid" --tile $i/4 --tile-scale "$scale" -o "$T/p$i.csip" "${tiles[@]}"
    check "[[ $? == 0 && -s '$T/p$i.csip' ]]" "--tile $i/4 --tile-scale"
done
for i in 0 2; do # the scale computed by the tile run itself
    "$B/csi-reconstruct" "$T/s.csid" --tile $i/4 -o "$T/p$i.csip" "${tiles[@]}"
    check "[[ $? == 0 && -s '$T/p$i.csip' ]]" "--tile $i/4"
done
"$B/csi-merge" "$T/p2.csip" "$T/p0.csip" "$T/p3.csip" "$T/p1.csip" -o "$T/m.exr" --png "$T/m.png" --stats "$T/m.json" -q
check "[[ $? == 0 && -s '$T/m.exr' && -s '$T/m.png' ]]" "csi-merge outputs"
check "[[ '$(json "$T/m.json" image_fnv1a64)' == '$ha' ]]" "merged tiles differ from the tiled run"
check "cmp -s '$T/s2.exr' '$T/m.exr'" "the merged EXR is not csi-reconstruct --tiles 4's, byte for byte (attributes)"
for i in 0 1 2 3; do
    "$B/csi-render" "$static" --tile $i/4 --tile-scale "$scale" -o "$T/r$i.csip" "${tiles[@]}"
    check "[[ $? == 0 ]]" "csi-render --tile $i/4"
done
"$B/csi-merge" "$T"/r?.csip -o "$T/rm.exr" --stats "$T/rm.json" -q
check "[[ '$(json "$T/rm.json" image_fnv1a64)' == '$ha' ]]" "csi-render's tiles differ from the tiled run"

# --- noisy samples: the cross-validated choice in each tile's window --------------------------
# Ambient occlusion of one ray makes the samples noisy (the blend and the choice apply) and two
# small lamps leak into the fit, so the choice gives some regions their means; each tile makes it
# in its window, and a tile run alone makes the same choice. The lamps' pixels settle on their
# means once, on the blended image: the merge does it from the partials' pixel sums.
cat > "$T/noisy.scene" <<'SCENE'
camera { position 0 0 -2.5 target 0 0 0 up 0 1 0 fov 40 size 32 32 }
background 0.3 0.3 0.3
ambient_occlusion { samples 1 distance 2 color 1 1 1 }
material grey { diffuse 0.8 0.7 0.6 }
material lamp { diffuse 0 0 0 emission 300 280 250 }
mesh {
  vertices { -0.62 -0.48 0.0   0.71 -0.29 0.4   -0.13 0.63 -0.2   -2 -2 1  2 -2 1  2 2 1  -2 2 1 }
  triangles { 0 1 2  3 4 5  3 5 6 }
  material grey
}
mesh {
  vertices { -0.5 0.3 -0.5  -0.3 0.35 -0.5  -0.42 0.5 -0.5   0.3 -0.5 -0.5  0.42 -0.45 -0.5  0.33 -0.3 -0.5 }
  triangles { 0 1 2  3 4 5 }
  material lamp
}
SCENE
"$B/csi-render" "$T/noisy.scene" --spp 4 --dump "$T/n.csid" -o "$T/n.exr" --stats "$T/n.json" --tiles 4 "${tiles[@]}"
check "[[ $? == 0 && '$(json "$T/n.json" cv_select)' == on ]]" "noisy samples in 4 tiles: the choice is $(json "$T/n.json" cv_select)"
check "[[ '$(json "$T/n.json" cv_switched_pixels)' -gt 0 ]]" "the tiles' choice gave no pixel its mean"
check "[[ '$(json "$T/n.json" settled_pixels)' -gt 0 ]]" "no pixel settled on the blended image (the merge's settling, from the partials' sums, goes untested)"
hn="$(json "$T/n.json" image_fnv1a64)"
for i in 2 0 3 1; do
    "$B/csi-reconstruct" "$T/n.csid" --tile $i/4 -o "$T/np$i.csip" "${tiles[@]}"
    check "[[ $? == 0 ]]" "noisy: --tile $i/4"
done
"$B/csi-merge" "$T"/np?.csip -o "$T/nm.exr" --stats "$T/nm.json" -q
check "[[ '$(json "$T/nm.json" image_fnv1a64)' == '$hn' ]]" "noisy: the merged tiles differ from the tiled run"
check "[[ '$(json "$T/nm.json" settled_pixels)' == '$(json "$T/n.json" settled_pixels)' ]]" "noisy: the merge settled $(json "$T/nm.json" settled_pixels) pixels, the tiled run $(json "$T/n.json" settled_pixels)"

# --- moving: time and space tiles, frames ---------------------------------------------------
# (time windows only when asked: --tiles-t; the budget alone splits x and y first)
"$B/csi-render" "$moving" --dump "$T/m.csid" -o "$T/mv.exr" --stats "$T/mv.json" --frames "$T/f1" --tiles 6 --tiles-t 3 "${tiles[@]}"
check "[[ $? == 0 ]] && grep -q '\"tiles\": 6,' '$T/mv.json'" "moving --tiles 6 --tiles-t 3"
"$B/csi-reconstruct" "$T/m.csid" --tiles 6 --tiles-t 3 --tile-info "${tiles[@]}" > "$T/minfo.json"
check "grep -q '\"tiles_x\": 2,' '$T/minfo.json' && grep -q '\"tiles_t\": 3,' '$T/minfo.json'" "2x1x3 layout: $(cat "$T/minfo.json")"
for i in 0 1 2 3 4 5; do
    "$B/csi-reconstruct" "$T/m.csid" --tiles-t 3 --tile $i/6 --partial-frames -o "$T/q$i.csip" "${tiles[@]}"
done
"$B/csi-merge" "$T"/q?.csip -o "$T/mm.exr" --frames "$T/f2" --stats "$T/mm.json" -q
check "[[ $? == 0 && '$(json "$T/mm.json" image_fnv1a64)' == '$(json "$T/mv.json" image_fnv1a64)' ]]" "moving tiles differ"
same=1; for f in "$T"/f1/*.png; do cmp -s "$f" "$T/f2/$(basename "$f")" || same=0; done
check "[[ $same == 1 && -s '$T/f2/frame_0007.png' ]]" "merged frames differ from the tiled run's"

# --- a side the FFT cannot take (37 x 23 pixels): the one-process run solves a grid padded right and
# down and crops it; the tile runs lay out the same problem (csi_tiling_layout) and the merge crops
sed 's/size 32 32/size 37 23/' "$static" > "$T/pad.scene"
"$B/csi-render" "$T/pad.scene" --dump "$T/pad.csid" -o "$T/pad_mean.exr" --estimator mean -q
# padded NAME SOLVED_WIDTH OPTIONS...: one process, then --tile-info and the tiles in reverse order
# merged: the same pixels, the image's own size, the layout over the grid of SOLVED_WIDTH pixels
padded() {
    local name="$1" want="$2"; shift 2
    "$B/csi-reconstruct" "$T/pad.csid" -o "$T/$name.exr" --stats "$T/$name.json" "$@"
    "$B/csi-reconstruct" "$T/pad.csid" --tile-info "$@" > "$T/$name.info"
    local n; n="$(json "$T/$name.info" tiles)"
    check "[[ '$(json "$T/$name.info" solved_out_w)' == $want && '$(json "$T/$name.json" tiles)' == '$n' ]]" \
        "$name: the layout is not over $want pixels or not the one-process run's: $(cat "$T/$name.info")"
    for ((i = n - 1; i >= 0; i--)); do
        "$B/csi-reconstruct" "$T/pad.csid" --tile $i/$n -o "$T/$name.$i.csip" "$@"
    done
    "$B/csi-merge" "$T/$name".*.csip -o "$T/$name.m.exr" --stats "$T/$name.m.json" -q
    check "[[ $? == 0 && '$(json "$T/$name.m.json" image_fnv1a64)' == '$(json "$T/$name.json" image_fnv1a64)' ]]" \
        "$name: the merged tiles differ from the one-process run"
    check "[[ '$(json "$T/$name.m.json" out_w)x$(json "$T/$name.m.json" out_h)' == 37x23 ]]" "$name: merged size"
    check "cmp -s '$T/$name.exr' '$T/$name.m.exr'" "$name: the merged EXR is not the one-process run's, byte for byte"
}
padded pad_whole 40 --max-iter 40 -q                            # the padded whole: one tile
padded pad_tiles 40 --tiles 2 --tile-margin 4 --max-iter 40 -q  # no 2 tiles of its own grid: of the padded one
padded pad_own 37 --tiles 4 --tile-margin 4 --max-iter 40 -q    # 2x2 tiles of its own grid
for i in 0 1; do
    "$B/csi-render" "$T/pad.scene" --tile $i/2 --tile-margin 4 --max-iter 40 -q -o "$T/padr$i.csip" \
        --tile-scale "$(json_text "$T/pad_tiles.info" tile_scale)"
done
"$B/csi-merge" "$T"/padr?.csip -o "$T/padr.exr" --stats "$T/padr.json" -q
check "[[ '$(json "$T/padr.json" image_fnv1a64)' == '$(json "$T/pad_tiles.json" image_fnv1a64)' ]]" \
    "csi-render's tiles of the padded grid differ from the one-process run"
expect_fail "a padded run's tile with another layout's" "pad_own.1.csip: tile 1 belongs to another run.*the tile layout" \
    "$B/csi-merge" "$T/pad_tiles.0.csip" "$T/pad_own.1.csip" -o "$T/out.exr"
# a volume padded in x and y, in tiles of the padded grid, with its frames
sed 's/size 32 32/size 37 23/' "$moving" > "$T/padm.scene"
"$B/csi-render" "$T/padm.scene" --dump "$T/padm.csid" -o "$T/padm_mean.exr" --estimator mean -q
"$B/csi-reconstruct" "$T/padm.csid" -o "$T/padm.exr" --stats "$T/padm.json" --frames "$T/pf1" --tiles 2 "${tiles[@]}"
"$B/csi-reconstruct" "$T/padm.csid" --tile-info --tiles 2 "${tiles[@]}" > "$T/padm.info"
for i in 1 0; do
    "$B/csi-reconstruct" "$T/padm.csid" --tile $i/2 --partial-frames -o "$T/padm$i.csip" "${tiles[@]}"
done
"$B/csi-merge" "$T"/padm?.csip -o "$T/padmm.exr" --frames "$T/pf2" --stats "$T/padmm.json" -q
check "[[ $? == 0 && '$(json "$T/padm.info" solved_out_w)' == 40 && '$(json "$T/padmm.json" image_fnv1a64)' == '$(json "$T/padm.json" image_fnv1a64)' ]]" \
    "a padded volume's merged tiles differ: $(cat "$T/padm.info")"
same=1; for f in "$T"/pf1/*.png "$T"/pf1/*.exr; do cmp -s "$f" "$T/pf2/$(basename "$f")" || same=0; done
check "[[ $same == 1 && -s '$T/pf2/frame_0007.png' ]] && cmp -s '$T/padm.exr' '$T/padmm.exr'" \
    "a padded volume's merged image or frames differ from the one-process run's (EXR bytes)"
# a volume of 11 frames, a count the FFT cannot take: solved on 12 (the last holds no sample), its
# image the mean over its own 11, in x/y tiles only (no time window over padding; 2 windows of 10
# frames would be tiles of its own grid)
"$B/csi-render" "$moving" --time-steps 11 --dump "$T/p11.csid" -o "$T/p11_mean.exr" --estimator mean -q
"$B/csi-reconstruct" "$T/p11.csid" -o "$T/p11.exr" --stats "$T/p11.json" --frames "$T/pf3" --tiles 2 --tiles-t 1 "${tiles[@]}"
"$B/csi-reconstruct" "$T/p11.csid" --tile-info --tiles 2 --tiles-t 1 "${tiles[@]}" > "$T/p11.info"
for i in 1 0; do
    "$B/csi-reconstruct" "$T/p11.csid" --tile $i/2 --tiles-t 1 --partial-frames -o "$T/p11_$i.csip" "${tiles[@]}"
done
"$B/csi-merge" "$T"/p11_?.csip -o "$T/p11m.exr" --frames "$T/pf4" --stats "$T/p11m.json" -q
check "[[ $? == 0 && '$(json "$T/p11.info" solved_t)' == 12 && '$(json "$T/p11.info" tiles_t)' == 1 && '$(json "$T/p11m.json" image_fnv1a64)' == '$(json "$T/p11.json" image_fnv1a64)' ]]" \
    "11 frames in 2 tiles: the merged image differs or the layout is not over 12 frames: $(cat "$T/p11.info")"
same=1; for f in "$T"/pf3/*.png "$T"/pf3/*.exr; do cmp -s "$f" "$T/pf4/$(basename "$f")" || same=0; done
cmp -s "$T/p11.exr" "$T/p11m.exr" || same=0
check "[[ $same == 1 && -s '$T/pf4/frame_0010.png' && ! -e '$T/pf4/frame_0011.png' && ! -e '$T/pf3/frame_0011.png' ]]" \
    "11 frames: the merged frames differ from the one-process run's, or a padding frame was written"
# 11 frames are padded to 12 for the FFT, but windows over its own 11 frames are tried first: what
# stops these is their margins, and the message says so (not the padding)
expect_fail "time windows over 11 frames, margins too wide" "2 time windows cannot be laid out on 11 frames with margins of 4" \
    "$B/csi-reconstruct" "$T/p11.csid" --tiles-t 2 --tile-margin-t 4 -o "$T/out.exr"

# --- progress where stderr is a file (a log): plain lines, at most one every CSI_PROGRESS s ------
prog=(--tile-margin 4 --max-iter 40)
CSI_PROGRESS=0.001 "$B/csi-reconstruct" "$T/m.csid" -o "$T/pg.exr" --stats "$T/pg.json" "${prog[@]}" 2> "$T/pg.err"
check "[[ $? == 0 ]] && grep -q '^csi-reconstruct: progress: solve 1/3' '$T/pg.err'" "progress lines: $(head -3 "$T/pg.err")"
check "! grep -q \$'[\r\e]' '$T/pg.err'" "a progress line holds a carriage return or an escape"
check "grep -q '^csi-reconstruct: progress: write [0-9]*%  .*pg.exr' '$T/pg.err'" "no progress line of the writing: $(tail -2 "$T/pg.err")"
"$B/csi-reconstruct" "$T/m.csid" -o "$T/pq.exr" --stats "$T/pq.json" "${prog[@]}" -q 2> "$T/pq.err"
check "[[ ! -s '$T/pq.err' && '$(json "$T/pq.json" image_fnv1a64)' == '$(json "$T/pg.json" image_fnv1a64)' ]]" \
    "quiet: nothing on stderr, the same pixels: $(cat "$T/pq.err")"
# a tiled run's time left: counted over every tile's channels, shown from the second solve on
CSI_PROGRESS=0 "$B/csi-reconstruct" "$T/s.csid" --tiles 4 -o "$T/pe.exr" "${prog[@]}" 2> "$T/pe.err"
check "[[ $? == 0 ]] && grep -q '^csi-reconstruct: progress: tile 4/4 solve [0-9]/[0-9] .* eta [0-9]*s' '$T/pe.err'" \
    "no time left in the last tile's progress: $(grep 'tile 4/4 solve' "$T/pe.err" | head -2)"
check "! grep -q '^csi-reconstruct: progress: tile 1/4 solve 1/.*eta' '$T/pe.err'" \
    "a time left before any solve was done: $(grep -m1 eta "$T/pe.err")"
CSI_PROGRESS=1000 "$B/csi-reconstruct" "$T/m.csid" -o "$T/pg.exr" "${prog[@]}" 2> "$T/pl.err"
check "[[ $? == 0 ]] && ! grep -q progress '$T/pl.err'" "a line before the first 1000 s: $(cat "$T/pl.err")"
CSI_PROGRESS=0.001 "$B/csi-reconstruct" "$T/m.csid" --tiles 2 --tile 1/2 -o "$T/pt.csip" "${prog[@]}" 2> "$T/pt.err"
check "[[ $? == 0 ]] && grep -q '^csi-reconstruct: progress: solve' '$T/pt.err' && grep -q '^csi-reconstruct: tile 1/2' '$T/pt.err'" \
    "a --tile run's progress: $(head -3 "$T/pt.err")"
CSI_PROGRESS=0.001 "$B/csi-render" "$static" -o "$T/pr.exr" "${prog[@]}" 2> "$T/pr.err"
check "[[ $? == 0 ]] && grep -q '^csi-render: progress: ' '$T/pr.err'" "csi-render's progress: $(head -3 "$T/pr.err")"
CSI_PROGRESS=0 "$B/csi-merge" "$T/p2.csip" "$T/p0.csip" "$T/p3.csip" "$T/p1.csip" -o "$T/pm.exr" 2> "$T/pm.err"
check "[[ $? == 0 ]] && grep -q '^csi-merge: progress: merge [0-9]*%  [1-4] of 4 tiles' '$T/pm.err'" "csi-merge's progress: $(head -3 "$T/pm.err")"
expect_fail "bad CSI_PROGRESS" "CSI_PROGRESS=often is not" env CSI_PROGRESS=often "$B/csi-reconstruct" "$T/m.csid" -o "$T/out.exr"

# --- bad input: exit 2, one line naming the problem, no output ---------------------------------
expect_fail "missing tile" "tile 3 of 4 is missing" "$B/csi-merge" "$T/p0.csip" "$T/p1.csip" "$T/p2.csip" -o "$T/out.exr"
expect_fail "repeated tile" "both hold tile 1" "$B/csi-merge" "$T/p0.csip" "$T/p1.csip" "$T/p1.csip" "$T/p3.csip" -o "$T/out.exr"
"$B/csi-reconstruct" "$T/s.csid" --tile 1/4 --tile-scale "$scale" -o "$T/other1.csip" --tile-margin 4 --max-iter 41 -q
expect_fail "foreign options" "reconstruction options" "$B/csi-merge" "$T/p0.csip" "$T/other1.csip" "$T/p2.csip" "$T/p3.csip" -o "$T/out.exr"
expect_fail "foreign input" "the input" "$B/csi-merge" "$T/p0.csip" "$T/r1.csip" "$T/p2.csip" "$T/p3.csip" -o "$T/out.exr"
"$B/csi-reconstruct" "$T/s.csid" --tile 1/2 -o "$T/half1.csip" "${tiles[@]}"
expect_fail "another layout" "layout" "$B/csi-merge" "$T/p0.csip" "$T/half1.csip" -o "$T/out.exr"
"$B/csi-render" "$static" --seed 2 --dump "$T/s2.csid" -o "$T/s2.exr" -q
"$B/csi-reconstruct" "$T/s2.csid" --tile 1/4 --tile-scale "$scale" -o "$T/dump1.csip" "${tiles[@]}"
expect_fail "foreign dump" "dump1.csip: tile 1 belongs to another run.*the input" "$B/csi-merge" "$T/p0.csip" "$T/dump1.csip" "$T/p2.csip" "$T/p3.csip" -o "$T/out.exr"
head -c 300 "$T/p2.csip" > "$T/trunc.csip"
expect_fail "truncated partial" "trunc.csip: checksum" "$B/csi-merge" "$T/p0.csip" "$T/p1.csip" "$T/trunc.csip" "$T/p3.csip" -o "$T/out.exr"
head -c 5 "$T/p2.csip" > "$T/head5.csip" # its magic and no more
expect_fail "a partial cut inside its header" "head5.csip: truncated: 5 bytes" "$B/csi-merge" "$T/p0.csip" "$T/head5.csip" -o "$T/out.exr"
# a byte of the pixels changed; the format version changed (byte 4)
size=$(stat -c %s "$T/p2.csip")
{ head -c $((size - 64)) "$T/p2.csip"; printf 'Z'; tail -c 63 "$T/p2.csip"; } > "$T/damaged.csip"
expect_fail "damaged partial" "damaged.csip: checksum" "$B/csi-merge" "$T/p0.csip" "$T/p1.csip" "$T/damaged.csip" "$T/p3.csip" -o "$T/out.exr"
# (version 5, before the chroma's grid was in it: a partial of the previous library)
{ head -c 4 "$T/p2.csip"; printf '\x05'; tail -c +6 "$T/p2.csip"; } > "$T/v5.csip"
expect_fail "another format version" "v5.csip: partial format version 5 (this program reads version 11)" "$B/csi-merge" "$T/p0.csip" "$T/p1.csip" "$T/v5.csip" "$T/p3.csip" -o "$T/out.exr"
expect_fail "not a partial" "not a csi tile partial" "$B/csi-merge" "$T/s.csid" -o "$T/out.exr"
# layouts written over a 2x2 tile with a valid checksum (tests/fuzz/make_seeds.py): the merge of
# the file alone once allocated the 60000x60000 image (14 GB), or a path for each of 4.3e9 tiles
hostile="$S/tests/fuzz/corpus/partial"
expect_fail "a layout csi does not make" "huge_image_one_tile: not a layout of tiles csi makes" \
    "$B/csi-merge" "$hostile/huge_image_one_tile" -o "$T/out.exr"
expect_fail "4.3e9 tiles, one given" "tile 1 of 4294836225 is missing" "$B/csi-merge" "$hostile/huge_tile_count" \
    -o "$T/out.exr"
expect_fail "no frames" "no frames" "$B/csi-merge" "$T"/p?.csip -o "$T/out.exr" --frames "$T/f3"
expect_fail "tile out of range" "--tile" "$B/csi-reconstruct" "$T/s.csid" --tile 4/4 -o "$T/out.exr"
expect_fail "tile and png" "csi-merge" "$B/csi-reconstruct" "$T/s.csid" --tile 0/4 -o "$T/out.exr" --png "$T/x.png"
expect_fail "too many tiles" "cannot be laid out" "$B/csi-reconstruct" "$T/s.csid" --tile 0/999 -o "$T/out.exr"
expect_fail "time windows of an image" "time windows asked for an image" "$B/csi-reconstruct" "$T/s.csid" --tiles-t 2 -o "$T/out.exr"
expect_fail "windows too long" "cannot be laid out on 8 frames" "$B/csi-reconstruct" "$T/m.csid" --tiles-t 2 --tile-margin-t 4 -o "$T/out.exr"

finish
