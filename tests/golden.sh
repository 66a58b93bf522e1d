#!/usr/bin/env bash
# The committed goldens (fixtures/golden/) are regenerated and compared byte for byte, so any change of output between
# commits fails and names the file. Deliberate changes: bash scripts/update-goldens.sh.
#   bash tests/golden.sh RTORACLE     (run from the repository root)
set -u
RTO=$1
. "$(dirname "$0")/cli_lib.sh"
G=fixtures/golden
[ -f "$G/SHA256SUMS" ] || { echo "FAIL: $G/SHA256SUMS missing (bash scripts/update-goldens.sh)"; exit 1; }
# The committed copy itself is intact.
(cd "$G" && sha256sum --quiet -c SHA256SUMS) >"$T/sums" 2>&1 || { fail "committed goldens do not match $G/SHA256SUMS"; sed 's/^/    | /' "$T/sums" | head; }
bash scripts/goldens.sh "$RTO" "$T/new" || fail "scripts/goldens.sh failed"
(cd "$G" && find . -type f ! -name SHA256SUMS | LC_ALL=C sort) >"$T/want"
(cd "$T/new" && find . -type f | LC_ALL=C sort) >"$T/got"
comm -23 "$T/want" "$T/got" | while read -r f; do echo "FAIL: golden file no longer written: ${f#./}"; done
comm -13 "$T/want" "$T/got" | while read -r f; do echo "FAIL: new file not in the goldens: ${f#./}"; done
cmp -s "$T/want" "$T/got" || fail "the set of golden files changed"
n=0
while read -r f; do
    [ -f "$T/new/$f" ] || continue
    n=$((n + 1))
    if ! cmp -s "$G/$f" "$T/new/$f"; then
        fail "output changed: ${f#./} ($(cmp "$G/$f" "$T/new/$f" 2>&1 | head -1 | sed 's|.*differ: ||'))"
    fi
done <"$T/want"
finish "golden: $n files byte-identical to fixtures/golden"
