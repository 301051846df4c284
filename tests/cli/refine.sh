#!/usr/bin/env bash
# csi-reconstruct --refine-request: the request (docs/dump-format.md, channels = 0) holds, for
# the pixels it picks, exactly the cells of their blocks that the dump did not sample, each once;
# the statistics count them; a share no pixel reaches writes nothing and says so; bad use (a
# volume, --tile, a share outside (0, 1], the mean estimator, --refine-with a request, a volume or
# samples no request asks for, both options, either with --settle on or --step-coverage on: the
# second pass samples the pixels those steps would move) exits 2 with one line and no file left
# behind.
# usage: refine.sh BUILD_DIR SOURCE_DIR
set -u
B="$1"; S="$2"
source "$(dirname "${BASH_SOURCE[0]}")/../support/testlib.sh"
R="$B/csi-reconstruct"

# The triangle at 4 spp (exact point values: the control-variate correction, which still leaves
# the edge pixels apart from their samples' means).
"$B/csi-render" "$S/tests/cli/scenes/small_triangle.scene" --spp 4 --seed 3 --dump "$T/d.csid" -o "$T/r.exr" \
    --max-iter 5 -q
"$R" "$T/d.csid" -o "$T/o.exr" --refine-request "$T/q.csid" --refine-share 0.01 --stats "$T/s.json" 2> "$T/err"
check "[[ $? == 0 && -s '$T/q.csid' ]]" "--refine-request: $(cat "$T/err")"
n=$(grep -o '"refine_cells": [0-9]*' "$T/s.json" | grep -o '[0-9]*$')
px=$(grep -o '"refine_pixels": [0-9]*' "$T/s.json" | grep -o '[0-9]*$')
check "[[ '$(dump_hdr "$T/q.csid")' == '256 256 1 32 32 0 $n' && $n -gt 0 ]]" "request header $(dump_hdr "$T/q.csid"), $n cells"
check "grep -q 'refine: $n cells of $px pixels' '$T/err'" "summary line: $(cat "$T/err")"
dump_xyt "$T/q.csid" 12 | sort > "$T/q.txt"
dump_xyt "$T/d.csid" 24 | sort > "$T/d.txt"
check "[[ -z \$(comm -12 '$T/q.txt' '$T/d.txt') ]]" "the request repeats sampled cells"
check "[[ \$(uniq '$T/q.txt' | wc -l) == $n ]]" "the request repeats a cell"
# per picked pixel (8 x 8 cells), requested + sampled = 64: its block is then sampled whole
awk '{print int($1 / 8), int($2 / 8)}' "$T/q.txt" | sort -u > "$T/qp.txt"
check "[[ \$(wc -l < '$T/qp.txt') == $px ]]" "the request covers $(wc -l < "$T/qp.txt") pixels, not $px"
cat "$T/q.txt" "$T/d.txt" | awk '{print int($1 / 8), int($2 / 8)}' | sort | uniq -c \
    | awk '{print $2, $3, $1}' > "$T/cnt.txt"
bad=$(join <(awk '{print $1 "_" $2}' "$T/qp.txt" | sort) <(awk '{print $1 "_" $2, $3}' "$T/cnt.txt" | sort) \
    | awk '$2 != 64' | wc -l)
check "[[ $bad == 0 ]]" "$bad picked pixels are not whole after the request"
# the same run, the same request
"$R" "$T/d.csid" -o "$T/o2.exr" --refine-request "$T/q2.csid" --refine-share 0.01 -q
check "cmp -s '$T/q.csid' '$T/q2.csid'" "two runs wrote different requests"

# a share no pixel reaches: nothing written, said on stderr
"$R" "$T/d.csid" -o "$T/o3.exr" --refine-request "$T/none.csid" --refine-share 1 2> "$T/err"
check "[[ $? == 0 && ! -e '$T/none.csid' ]] && grep -q 'no pixel to refine' '$T/err'" \
      "share 1: $(cat "$T/err")"

# refused before any work: exit 2, one line, nothing written
"$B/csi-render" "$S/tests/cli/scenes/small_moving.scene" --spp 2 --seed 5 --dump "$T/m.csid" -o "$T/m.exr" \
    --max-iter 5 -q
for args in "$T/m.csid --refine-request $T/x.csid" "$T/d.csid --refine-request $T/x.csid --refine-share 0" \
            "$T/d.csid --refine-request $T/x.csid --refine-share 1.5" \
            "$T/d.csid --refine-request $T/x.csid --refine-share abc" \
            "$T/d.csid --refine-request $T/x.csid --tile 1/2" \
            "$T/d.csid --refine-request $T/x.csid --estimator mean" \
            "$T/m.csid --refine-with $T/m.csid" "$T/d.csid --refine-with $T/q.csid" \
            "$T/d.csid --refine-request $T/x.csid --refine-with $T/d.csid" \
            "$T/d.csid --refine-request $T/x.csid --settle on" "$T/d.csid --refine-with $T/q.csid --settle on" \
            "$T/d.csid --refine-request $T/x.csid --step-coverage on" \
            "$T/d.csid --refine-with $T/q.csid --step-coverage on" \
            "$T/d.csid --refine-share 0.1"; do
    rm -f "$T/x.exr"
    $R $args -o "$T/x.exr" 2> "$T/err"
    rc=$?
    check "[[ $rc == 2 && \$(wc -l < '$T/err') == 1 && ! -e '$T/x.exr' && ! -e '$T/x.csid' ]]" \
          "refused ($args): exit $rc: $(cat "$T/err")"
done
# --refine-with given samples that no refinement request asks for (another seed's dump of the same
# grid: cells the first dump sampled, pixels left incomplete) is refused before the
# reconstruction, by what every request's evaluation is whatever the image
"$B/csi-render" "$S/tests/cli/scenes/small_triangle.scene" --spp 4 --seed 4 --dump "$T/d4.csid" -o "$T/r4.exr" \
    --max-iter 5 -q
rm -f "$T/x.exr"
"$R" "$T/d.csid" --refine-with "$T/d4.csid" -o "$T/x.exr" 2> "$T/err"
rc=$?
check "[[ $rc == 2 && \$(wc -l < '$T/err') == 1 && ! -e '$T/x.exr' ]] && grep -Eq 'sampled in .* already|completes every pixel' '$T/err'" \
      "--refine-with another dump: exit $rc: $(cat "$T/err")"
finish
