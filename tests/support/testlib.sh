# The command-line tests' (tests/cli) shared harness, as testlib.h is for the C tests: a
# scratch folder $T removed at exit, counting checks, and the refusal contract every program
# keeps (exit 2, one line naming the problem, no output and no temporary left behind).
# A test sources it after setting B (build dir) and S (source dir), and ends with `finish`.
T="$(mktemp -d)"; trap 'rm -rf "$T"' EXIT
pass=0; fail=0
ok()    { pass=$((pass + 1)); }
bad()   { fail=$((fail + 1)); echo "FAIL: $*" >&2; }
check() { if eval "$1"; then ok; else bad "$2"; fi; }
# json FILE KEY: the first value of KEY in a JSON file (strings without their quotes)
json()  { sed -n "s/.*\"$2\": \"\\{0,1\\}\\([^\",]*\\).*/\\1/p" "$1" | head -1; }
# json_text FILE KEY: the whole quoted string value of KEY (commas included, e.g. tile_scale's)
json_text() { sed -n "s/.*\"$2\": \"\\([^\"]*\\)\".*/\\1/p" "$1" | head -1; }
# expect_fail NAME WANT CMD...: CMD exits 2 with one line on stderr containing WANT, and leaves
# neither $T/out.exr nor $T/out.csid nor a hidden temporary of either.
expect_fail() {
    local name="$1" want="$2"; shift 2
    rm -f "$T/out.exr" "$T/out.csid"
    "$@" > "$T/o" 2> "$T/e"; local rc=$?
    local lines; lines=$(wc -l < "$T/e")
    if [[ $rc == 2 && $lines == 1 ]] && grep -q -- "$want" "$T/e" && \
       [[ ! -e "$T/out.exr" && ! -e "$T/out.csid" ]] && ! ls -A "$T" | grep -q '^\.out'; then
        ok
    else
        bad "$name: rc=$rc lines=$lines: $(cat "$T/e")"
    fi
}
# A dump's header fields as unsigned 32-bit words: grid_w grid_h grid_t out_w out_h channels count_lo
dump_hdr() { od -An -v -tu4 -j8 -N28 "$1" | tr -s ' \n' ' ' | sed 's/^ //; s/ $//'; }
# The (x, y, t) of every record of a dump whose records are $2 bytes long
dump_xyt() { od -An -v -tu4 -j64 -w"$2" "$1" | awk '{print $1, $2, $3}'; }
finish() { echo "$pass passed, $fail failed"; [[ $fail == 0 ]]; }
