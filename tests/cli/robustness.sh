#!/usr/bin/env bash
# What the programs promise against hostile input (issue 14), end to end:
#   - sizes before work: oversized dumps and scenes refused before the work (seconds, not minutes) with little memory
#     (limits set here: CSI_HOST_MEMORY_LIMIT, never the machine's free memory);
#   - outputs all or nothing: a write failure injected after each output file (CSI_FAIL_OUTPUT=N)
#     leaves the directory exactly as it was (no new file, folder or temporary, replaced files
#     intact), for csi-render with every kind of output, into a new and an existing frames folder;
#   - no input overwritten: an output naming an input (the same path, a hard or symbolic link, a
#     texture of the scene) or two outputs naming one file are refused before work;
#   - inputs: FIFOs, devices and directories refused by what they are, without blocking;
#   - control characters of input names escaped in messages; EXR bytes reproducible.
# usage: robustness.sh BUILD_DIR SOURCE_DIR
set -u
B="$1"; S="$2"
source "$(dirname "${BASH_SOURCE[0]}")/../support/testlib.sh"
static="$S/tests/cli/scenes/small_triangle.scene"
moving="$S/tests/cli/scenes/small_moving.scene"
fast=(--max-iter 20 -q)
now_ms() { date +%s%3N; }
# what a directory holds: every file with its size and time, every folder (their times change when
# a temporary file comes and goes)
listing() { (cd "$1" && { find . -mindepth 1 -type d -printf '%p/\n'; find . -type f -printf '%p %s %T@\n'; } | sort); }

# A dump header declaring grid W H T, output OW OH, C channels and N records (zero-valued).
mkheader() { # file w h t ow oh c n
    python3 - "$@" <<'EOF'
import struct, sys
f, w, h, t, ow, oh, c, n = sys.argv[1], *map(int, sys.argv[2:])
hdr = b"CSID" + struct.pack("<7I", 1, w, h, t, ow, oh, c) + struct.pack("<QQ", n, 0) + bytes(16)
rec = struct.pack("<3I", 0, 0, 0) + struct.pack("<%df" % c, *([0.5] * c))
open(f, "wb").write(hdr + rec * n)
EOF
}

# refused FILE: exit 2, one line containing WANT, under 300 MB of peak RSS: before the work, which
# for these inputs takes minutes and gigabytes. Refusal times are measured in
# docs/bench/robustness.md, not asserted here; the 120 s timeout only turns a hang (the work
# started after all) into a failure instead of a stuck suite.
refused() { # name want cmd...
    local name="$1" want="$2"; shift 2
    local t0 t1 rc
    t0=$(now_ms)
    timeout 120 /usr/bin/time -f '%M' -o "$T/rss" "$@" > /dev/null 2> "$T/e"; rc=$?
    t1=$(now_ms)
    local rss; rss=$(tail -1 "$T/rss")
    if [[ $rc == 2 && $(wc -l < "$T/e") == 1 ]] && grep -q -- "$want" "$T/e" && ((rss < 300000)); then
        ok
    else
        bad "$name: rc=$rc $((t1 - t0)) ms ${rss} KB: $(cat "$T/e")"
    fi
}

# --- sizes before work ---------------------------------------------------------------------------
mkheader "$T/huge.csid" 65536 65536 1 65536 65536 3 1
refused "4 G cells" "huge.csid: byte 8: grid 65536x65536x1" "$B/csi-reconstruct" "$T/huge.csid" -o "$T/o.exr"
# 11 cells per pixel: no padding of the image makes a length the FFT takes (a hang, once)
mkheader "$T/f11.csid" 176 176 1 16 16 3 1
refused "11 cells per pixel" "prime factor" "$B/csi-reconstruct" "$T/f11.csid" -o "$T/o.exr"
mkheader "$T/big.csid" 16384 16384 1 8192 8192 3 1
CSI_HOST_MEMORY_LIMIT=$((512 << 20)) refused "host memory" "host memory" \
    "$B/csi-reconstruct" "$T/big.csid" -o "$T/o.exr"
# the sample mean is never tiled: its 24 GiB output buffer is over a 1 GB device (POCL_MEMORY_LIMIT)
mkheader "$T/wide.csid" 65536 32768 1 65536 32768 3 1
POCL_MEMORY_LIMIT=1 refused "device buffer" "wide.csid: grid 65536x32768x1 (2147483648 cells), 1 samples: sample mean needs a 24.0 GiB device buffer" \
    "$B/csi-reconstruct" "$T/wide.csid" -o "$T/o.exr" --estimator mean
mkheader "$T/frames.csid" 4 4 65536 1 1 1 48
refused "grid_t 65536" "grid_t = 65536 frames is more than the limit 1024" "$B/csi-reconstruct" "$T/frames.csid" -o "$T/o.exr"
sed 's/size 32 32/size 8192 8192/' "$static" > "$T/s8192.scene"
refused "scene 8192^2" "s8192.scene" "$B/csi-render" "$T/s8192.scene" -o "$T/o.exr"
sed 's/size 32 32/size 2048 2048/' "$static" > "$T/s2048.scene"
CSI_HOST_MEMORY_LIMIT=$((256 << 20)) refused "scene 2048^2, host memory" "s2048.scene: grid" \
    "$B/csi-render" "$T/s2048.scene" -o "$T/o.exr"
# a spinning mesh of 4000 triangles: 129 vertex buffers (Embree's time steps) and its motion BVH
# take about 45 MiB when traced (csi_tracer_host_bytes counts 65 MiB), while the reconstruction of
# its 16x16x64 grid needs under 2 MiB: refused under a 40 MiB host limit only if the tracer is
# counted (a small mesh: the OBJ is read before the refusal)
awk 'BEGIN { for (i = 0; i < 4000; i++) { x = (i % 200) * 0.01; y = int(i / 200) * 0.01;
             printf "v %g %g 0\nv %g %g 0\nv %g %g 0\nf %d %d %d\n", x, y, x + 0.01, y, x, y + 0.01, 3*i+1, 3*i+2, 3*i+3 } }' \
    > "$T/spin.obj"
printf 'camera { position 0 0 -3 target 0 0 0 size 16 16 }\nmaterial m { diffuse 1 1 1 }\nmesh { file "spin.obj" material m motion { key 0 { } key 1 { rotate 0 1 0 720 } } }\n' > "$T/spin.scene"
CSI_HOST_MEMORY_LIMIT=$((40 << 20)) refused "spinning mesh, host memory" "spin.scene: grid .*for the samples and inputs" \
    "$B/csi-render" "$T/spin.scene" -o "$T/o.exr"
sed 's/frames 8/frames 4096/' "$moving" > "$T/f4096.scene"
refused "frames 4096" "integer in \[1, 1024\]" "$B/csi-render" "$T/f4096.scene" -o "$T/o.exr"
[[ ! -e "$T/o.exr" ]] && ok || bad "a refused run left o.exr"

# --- outputs all or nothing ----------------------------------------------------------------------
# Every output of csi-render; a failure after each of them leaves the directory as it was.
mkdir -p "$T/aon"
printf 'OLD' > "$T/aon/out.exr"   # an existing file the run would replace: it must survive a failure
run_all() { # extra env... ; frames dir name
    local frames="$1"; shift
    env "$@" "$B/csi-render" "$moving" -o "$T/aon/out.exr" --png "$T/aon/out.png" --stats "$T/aon/out.json" \
        --dump "$T/aon/out.csid" --frames "$T/aon/$frames" --time-steps 2 --spp 1 "${fast[@]}" 2> "$T/e"
}
for frames in newframes oldframes; do
    [[ $frames == oldframes ]] && mkdir -p "$T/aon/oldframes" && printf 'OLD' > "$T/aon/oldframes/frame_0001.exr"
    before="$(listing "$T/aon")"
    n=1; done_ok=0
    while ((n < 80)); do
        run_all "$frames" CSI_FAIL_OUTPUT=$n; rc=$?
        if [[ $rc == 0 ]]; then done_ok=1; break; fi
        after="$(listing "$T/aon")"
        if [[ "$after" != "$before" || $(cat "$T/aon/out.exr") != OLD ]]; then
            bad "failure at output event $n ($frames) changed the directory: $(diff <(echo "$before") <(echo "$after") | head -5)"
            break
        fi
        [[ $(wc -l < "$T/e") == 1 ]] || bad "failure at event $n: not one line: $(cat "$T/e")"
        n=$((n + 1))
    done
    # 4 frame files + EXR, PNG, stats, dump: 8 writes, then their renames, failed in turn
    if [[ $done_ok == 1 && $n -gt 8 ]]; then ok; else bad "$frames: succeeded after $n events (rc $rc): $(cat "$T/e")"; fi
    [[ -s "$T/aon/$frames/frame_0001.png" && -s "$T/aon/out.csid" && $(head -c 3 "$T/aon/out.exr") != OLD ]] \
        && ok || bad "$frames: outputs missing after the successful run"
    rm -rf "$T/aon/newframes" "$T/aon/out.png" "$T/aon/out.json" "$T/aon/out.csid"
    printf 'OLD' > "$T/aon/out.exr"
done
# A bad --png (a directory) after a good -o: nothing written, not even the EXR.
mkdir -p "$T/aon2/dir.png"
"$B/csi-render" "$static" -o "$T/aon2/out.exr" --png "$T/aon2/dir.png" "${fast[@]}" 2> "$T/e"; rc=$?
[[ $rc == 2 && ! -e "$T/aon2/out.exr" ]] && ok || bad "--png DIR: rc=$rc, $(ls "$T/aon2"): $(cat "$T/e")"
# A bad dump: the new frames folder is not created.
printf 'XXXX' > "$T/bad.csid"
"$B/csi-reconstruct" "$T/bad.csid" -o "$T/aon2/r.exr" --frames "$T/aon2/fr" -q 2> /dev/null
[[ ! -e "$T/aon2/fr" && ! -e "$T/aon2/r.exr" ]] && ok || bad "bad dump left $(ls "$T/aon2")"

# An interrupted run (SIGTERM while its outputs are being written) leaves nothing either.
mkdir -p "$T/intr"
mkheader "$T/intr.csid" 8192 8192 1 4096 4096 3 1
"$B/csi-reconstruct" "$T/intr.csid" -o "$T/intr/o.exr" --png "$T/intr/o.png" --estimator mean -q 2> /dev/null &
pid=$!
seen=0
for i in $(seq 1 3000); do   # up to 30 s for the first temporary output to appear
    if ls -A "$T/intr" | grep -q .; then seen=1; break; fi
    kill -0 $pid 2> /dev/null || break
    sleep 0.01
done
kill -TERM $pid 2> /dev/null; wait $pid 2> /dev/null
if [[ $seen == 1 ]]; then
    [[ -z "$(ls -A "$T/intr")" ]] && ok || bad "SIGTERM while writing left: $(ls -A "$T/intr")"
else
    bad "the interrupted run wrote nothing to interrupt"
fi

# --- no input overwritten ------------------------------------------------------------------------
"$B/csi-render" "$static" -o "$T/s.exr" --dump "$T/s.csid" "${fast[@]}" || bad "render for the dump"
cp "$static" "$T/t.scene"
cp "$S/tests/data/io/img_rgb.png" "$T/img.png"
ln -f "$T/s.csid" "$T/hard.csid"; ln -sf "$T/s.csid" "$T/soft.csid"
cp "$T/s.csid" "$T/more.csid" # an input stated after the outputs (--refine-with)
sum_before="$(md5sum "$T/s.csid" "$T/t.scene" "$T/img.png" "$T/more.csid")"
same() { # name want cmd...
    local name="$1" want="$2"; shift 2
    "$@" > /dev/null 2> "$T/e"; local rc=$?
    if [[ $rc == 2 && $(wc -l < "$T/e") == 1 ]] && grep -q -- "$want" "$T/e"; then ok; else bad "$name: rc=$rc: $(cat "$T/e")"; fi
}
same "dump -o itself" "would overwrite the input" "$B/csi-reconstruct" "$T/s.csid" -o "$T/s.csid"
same "dump --stats hard link" "would overwrite the input" "$B/csi-reconstruct" "$T/s.csid" -o "$T/x.exr" --stats "$T/hard.csid"
same "dump --png symlink" "would overwrite the input" "$B/csi-reconstruct" "$T/s.csid" -o "$T/x.exr" --png "$T/soft.csid"
same "scene -o itself" "would overwrite the input" "$B/csi-render" "$T/t.scene" -o "$T/t.scene"
same "scene --dump itself" "would overwrite the input" "$B/csi-render" "$T/t.scene" -o "$T/x.exr" --dump "$T/t.scene"
same "mkdump -o its image" "would overwrite the input" "$B/csi-mkdump" "$T/img.png" -o "$T/img.png" --out 4x3
same "--refine-with -o itself" "would overwrite the input" "$B/csi-reconstruct" "$T/s.csid" --refine-with "$T/more.csid" -o "$T/more.csid"
same "two outputs, one file" "are the same file" "$B/csi-reconstruct" "$T/s.csid" -o "$T/y.exr" --png "$T/y.exr"
same "two outputs, one file via ./" "are the same file" "$B/csi-reconstruct" "$T/s.csid" -o "$T/y.exr" --stats "$T/./y.exr"
printf 'camera { position 0 0 -2 target 0 0 0 size 8 8 }\nmaterial m { texture "tex.png" }\n' > "$T/tx.scene"
cp "$S/tests/data/io/img_rgb.png" "$T/tex.png"
same "scene texture as --png" "would overwrite the input" "$B/csi-render" "$T/tx.scene" -o "$T/x.exr" --png "$T/tex.png"
# -o writes OpenEXR and --png a PNG: a name asking for the other format is refused, not obeyed in name only
same "-o named .png" "x.png: the image (-o) is written as OpenEXR, not png" "$B/csi-reconstruct" "$T/s.csid" -o "$T/x.png"
same "--png named .EXR" "z.EXR: the preview (--png) is written as an 8-bit PNG, not exr" "$B/csi-render" "$T/t.scene" -o "$T/x.exr" --png "$T/z.EXR"
same "-o named .jpg" "x.jpg: the image (-o) is written as OpenEXR, not jpg" "$B/csi-render" "$T/t.scene" -o "$T/x.jpg"
[[ "$(md5sum "$T/s.csid" "$T/t.scene" "$T/img.png" "$T/more.csid")" == "$sum_before" && ! -e "$T/x.exr" && ! -e "$T/y.exr" \
   && ! -e "$T/x.png" && ! -e "$T/z.EXR" && ! -e "$T/x.jpg" ]] \
    && ok || bad "an input changed or an output was written"

# --- inputs that are not regular files -----------------------------------------------------------
mkfifo "$T/fifo.csid" "$T/fifo.scene"
same "FIFO dump" "fifo.csid: cannot open sample dump: a FIFO" timeout 10 "$B/csi-reconstruct" "$T/fifo.csid" -o "$T/o.exr"
same "FIFO scene" "fifo.scene: cannot open scene: a FIFO" timeout 10 "$B/csi-render" "$T/fifo.scene" -o "$T/o.exr"
same "device scene" "/dev/zero: cannot open scene: a character device" "$B/csi-render" /dev/zero -o "$T/o.exr"
same "directory dump" "cannot open sample dump: a directory" "$B/csi-reconstruct" "$T" -o "$T/o.exr"
same "device image" "cannot open image: a character device" "$B/csi-mkdump" /dev/zero -o "$T/o.csid" --out 4x4

# --- a variance dump that is not the dump's (csi-reconstruct --variance) --------------------------
# s4.csid: a 4x4 image on a 16x16 grid, one sample per pixel; its variances v.csid; then variance
# dumps at other positions, of other channels, with a negative value. Each is refused before the
# work with one line naming it; the matching one reconstructs.
python3 - "$T" <<'EOF2'
import struct, sys
T = sys.argv[1]
def dump(name, pos, vals, c=3):
    hdr = b"CSID" + struct.pack("<7I", 1, 16, 16, 1, 4, 4, c) + struct.pack("<QQ", len(pos), 0) + bytes(16)
    body = b"".join(struct.pack("<3I", x, y, 0) + struct.pack("<%df" % c, *v) for (x, y), v in zip(pos, vals))
    open(f"{T}/{name}", "wb").write(hdr + body)
pos = [(4 * i + 1, 4 * j + 1) for j in range(4) for i in range(4)]
dump("s4.csid", pos, [(1 + k % 3, 2.0, 0.5) for k in range(16)])
dump("v.csid", pos, [(0.01, 0.01, 0.01)] * 16)
dump("vo.csid", [(x + 1, y) for x, y in pos], [(0.01, 0.01, 0.01)] * 16)
dump("vc.csid", pos, [(0.01,)] * 16, c=1)
dump("vn.csid", pos, [(0.01, -1.0, 0.01) if k == 3 else (0.01, 0.01, 0.01) for k in range(16)])
EOF2
"$B/csi-reconstruct" "$T/s4.csid" -o "$T/v.exr" --variance "$T/v.csid" "${fast[@]}" && [[ -s "$T/v.exr" ]] && ok ||
    bad "--variance with the dump's own variances failed"
refused "variances at other positions" "vo.csid: record 0 is at (2, 1, 0)" \
    "$B/csi-reconstruct" "$T/s4.csid" -o "$T/o.exr" --variance "$T/vo.csid"
refused "variances of other channels" "vc.csid: 16 records of 1 channels" \
    "$B/csi-reconstruct" "$T/s4.csid" -o "$T/o.exr" --variance "$T/vc.csid"
refused "a negative variance" "vn.csid: record 3 channel 1: variance -1 is negative" \
    "$B/csi-reconstruct" "$T/s4.csid" -o "$T/o.exr" --variance "$T/vn.csid"
refused "variances with --drop-invalid" "--variance and --drop-invalid" \
    "$B/csi-reconstruct" "$T/s4.csid" -o "$T/o.exr" --variance "$T/v.csid" --drop-invalid
[[ ! -e "$T/o.exr" ]] && ok || bad "a refused --variance run wrote its output"
# The variances beside a dump (X.variance.csid) are taken by default, said on stderr, and give the
# bits of naming them; --variance none ignores them; a found file that is not the dump's is
# refused with the hint, before the work.
mkdir -p "$T/side" && cp "$T/s4.csid" "$T/side/a.csid" && cp "$T/v.csid" "$T/side/a.variance.csid"
"$B/csi-reconstruct" "$T/side/a.csid" -o "$T/side/e.exr" --variance "$T/side/a.variance.csid" "${fast[@]}" -q
msg=$("$B/csi-reconstruct" "$T/side/a.csid" -o "$T/side/f.exr" --max-iter 20 2>&1 >/dev/null)
[[ "$msg" == *"each sample's variance from $T/side/a.variance.csid"* ]] && cmp -s "$T/side/e.exr" "$T/side/f.exr" &&
    ok || bad "the variances beside a dump were not taken as --variance takes them: $msg"
msg=$("$B/csi-reconstruct" "$T/side/a.csid" -o "$T/side/n.exr" --variance none --max-iter 20 2>&1 >/dev/null)
[[ "$msg" != *"variance from"* && -s "$T/side/n.exr" ]] && ok || bad "--variance none still took them: $msg"
cp "$T/vo.csid" "$T/side/a.variance.csid"
refused "variances beside the dump at other positions" \
    "a.variance.csid: record 0 is at (2, 1, 0), .*a.csid's at (1, 1, 0): not its variances (found beside the dump; --variance none ignores it)" \
    "$B/csi-reconstruct" "$T/side/a.csid" -o "$T/o.exr"
[[ ! -e "$T/o.exr" ]] && ok || bad "a refused run with the variances beside the dump wrote its output"

# --- messages: control characters escaped ---------------------------------------------------------
esc=$'\e[31mred\e[0m.csid'
"$B/csi-reconstruct" "$T/$esc" -o "$T/o.exr" 2> "$T/e"
if grep -q $'\e' "$T/e"; then bad "an escape character reached stderr"; elif grep -qF '\x1b[31mred' "$T/e"; then ok; else bad "escaped name: $(cat "$T/e")"; fi

# --- EXR bytes reproducible ----------------------------------------------------------------------
"$B/csi-reconstruct" "$T/s.csid" -o "$T/r1.exr" "${fast[@]}" && "$B/csi-reconstruct" "$T/s.csid" -o "$T/r2.exr" "${fast[@]}"
cmp -s "$T/r1.exr" "$T/r2.exr" && ok || bad "two runs of the same dump wrote different EXR bytes"

finish
