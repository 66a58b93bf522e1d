# Shared by the command-line tests (sourced): a scratch directory $T, and run / has / fail / finish helpers.
T=$(mktemp -d)
# Removed by this shell alone: a child bash forks for a background job keeps the trap until it execs, and a signal the
# test sends it in that moment (cli.signals sends SIGINT after 0 ms) would otherwise run the trap there and take $T
# away under the test.
T_OWNER=$BASHPID
trap '[ "$BASHPID" != "$T_OWNER" ] || rm -rf "$T"' EXIT
failures=0
# sampled N: 1 in the optimised build, N under the sanitizer (scripts/test.sh sets RTO_TEST_SANITIZED there): the
# stride of the longest loops, which then take every Nth case.
sampled() { if [ -n "${RTO_TEST_SANITIZED:-}" ]; then echo "$1"; else echo 1; fi; }

fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
# run WANT_RC CMD... : runs CMD, keeps stdout/stderr in $T/out, $T/err, checks the exit status.
run() {
    local want=$1
    shift
    "$@" >"$T/out" 2>"$T/err"
    local rc=$?
    if [ "$rc" != "$want" ]; then
        fail "exit $rc (want $want): $*"
        sed 's/^/    | /' "$T/out" "$T/err" | head -20
        return 1
    fi
    return 0
}
# has TEXT out|err : the last command's stdout / stderr contains TEXT.
has() { grep -q -- "$1" "$T/$2" || { fail "expected '$1' in $2 of the last command"; sed 's/^/    | /' "$T/$2" | head -20; }; }
# loc KEY VALUE : the last command's JSON report (stdout) locates its fault at KEY = VALUE.
loc() {
    sed -n '/"location": {/,/}/p' "$T/out" | grep -Eq "^ *\"$1\": $2,?\$" ||
        { fail "expected location $1 = $2"; sed -n '/"location"/,/}/p' "$T/out" | sed 's/^/    | /'; }
}
# peak RTO ARGS...: runs RTO ARGS, keeping stdout/stderr in $T/out, $T/err; prints "STATUS PEAK-KIB SECONDS".
peak() {
    python3 -c 'import resource, subprocess, sys, time
t = time.monotonic(); r = subprocess.run(sys.argv[2:], stdout=open(sys.argv[1], "w"), stderr=open(sys.argv[1] + ".e", "w"))
print(r.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, round(time.monotonic() - t, 2))' \
        "$T/out" "$@"
    mv "$T/out.e" "$T/err"
}
# bounded WANT_RC LABEL RTO ARGS...: the run ends WANT_RC within 5 s (well under a second on the 2-core machine; the
# rest is room for a loaded one) and under 300 MB of peak RSS, with one line on stderr when it refuses.
bounded() {
    local want=$1 label=$2 rc kib secs
    shift 2
    peak "$@" >"$T/peak"
    read -r rc kib secs <"$T/peak"
    [ "$rc" = "$want" ] && [ "$kib" -lt 307200 ] && awk -v s="$secs" 'BEGIN { exit !(s < 5) }' ||
        fail "$label: exit $rc, peak $kib KiB, $secs s (want $want, < 300 MB, < 5 s)"
    [ "$want" != 2 ] || [ "$(wc -l <"$T/err")" = 1 ] || fail "$label: not one line: $(cat "$T/err")"
}
# finish MESSAGE : exits 1 if anything failed, else prints MESSAGE.
finish() {
    if [ "$failures" != 0 ]; then
        echo "$failures failure(s)"
        exit 1
    fi
    echo "$1"
}
