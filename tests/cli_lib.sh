# Shared by the command-line tests (sourced): a scratch directory $T, and run / has / fail / finish helpers.
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
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
# finish MESSAGE : exits 1 if anything failed, else prints MESSAGE.
finish() {
    if [ "$failures" != 0 ]; then
        echo "$failures failure(s)"
        exit 1
    fi
    echo "$1"
}
