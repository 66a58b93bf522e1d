#!/usr/bin/env bash
# The sanitizer build's leak detection works under the options the suite runs with (scripts/test.sh's ASAN_OPTIONS):
# a clean run that dlopens the image module passes, and a planted leak fails with LeakSanitizer's report naming the
# leaking function, not with the sanitizer runtime's own fatal error (google/sanitizers#1322).
#   bash tests/sanitizer_leak.sh PLANTED_LEAK FIXTURES
set -u
. "$(dirname "$0")/cli_lib.sh"
leak=$1
scene=$2/Duck/glTF/Duck.gltf
case ":${ASAN_OPTIONS:-}:" in
*:detect_leaks=1:*) ;;
*) fail "ASAN_OPTIONS ('${ASAN_OPTIONS:-}') does not turn leak detection on; run under scripts/test.sh's options" ;;
esac
run 0 "$leak" "$scene"
"$leak" "$scene" leak >"$T/out" 2>"$T/err"
rc=$?
[ "$rc" != 0 ] || fail "a planted leak exited 0"
has "ERROR: LeakSanitizer: detected memory leaks" err
has "planted_leak_alloc" err
! grep -q "LeakSanitizer has encountered a fatal error" "$T/err" || fail "the sanitizer runtime itself failed"
finish "sanitizer: a planted leak is reported by name (status $rc); a clean run that loads the image module passes"
