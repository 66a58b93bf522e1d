#!/usr/bin/env bash
# scripts/deps.sh's install logic without touching the system: dpkg-query, apt-get, npm, id and sudo are stubs on PATH
# that answer from environment variables and record every call. Each case checks the exit status, the calls made and
# the one-line message, under `set -euo pipefail` as main.sh and test.sh source it.
#   bash tests/scripts_deps.sh SCRIPTS/deps.sh
set -u
. "$(dirname "$0")/cli_lib.sh"
DEPS=$(realpath "$1")
S=$T/stubs
mkdir -p "$S"

# dpkg-query -W -f=FORMAT PKG...: FORMAT with status "ii " for the names in $STUB_INSTALLED, "un " for those in
# $STUB_REMOVED, and for any other name dpkg's complaint on stderr and, at the end, status 1, as the real one does.
cat >"$S/dpkg-query" <<'EOF'
#!/bin/bash
echo "dpkg-query $*" >>"$STUB_LOG"
[ "$1" = -W ] || exit 64
shift
fmt='${binary:Package}\t${Version}\n'
case $1 in -f=*) fmt=${1#-f=}; shift ;; esac
# The format's fields that deps.sh may ask for; the escape \n as dpkg-query expands it.
show() {
    local out=${fmt//'${db:Status-Abbrev}'/$1}
    out=${out//'${Package}'/$2}
    printf '%b' "${out//'${Version}'/1.0}"
}
rc=0
for p in "$@"; do
    if [[ " $STUB_INSTALLED " == *" $p "* ]]; then show "ii " "$p"
    elif [[ " ${STUB_REMOVED:-} " == *" $p "* ]]; then show "un " "$p"
    else echo "dpkg-query: no packages found matching $p" >&2; rc=1; fi
done
exit $rc
EOF
# apt-get update | install -y -q --no-install-recommends PKG...: fails as apt does for a name in $STUB_UNKNOWN, and
# with a fetch error when $STUB_APT_FAIL is set.
cat >"$S/apt-get" <<'EOF'
#!/bin/bash
echo "apt-get $*" >>"$STUB_LOG"
[ "$1" = update ] && { echo "Hit:1 http://deb.debian.org/debian bookworm InRelease"; : >"$STUB_LOG.updated"; exit 0; }
[ "$1" = install ] || exit 64
# No package lists yet (a fresh image): nothing can be located before an update.
[ -n "${STUB_APT_STALE:-}" ] && [ ! -f "$STUB_LOG.updated" ] && { echo "E: Unable to locate package ${!#}"; exit 100; }
for p in "$@"; do
    [[ " ${STUB_UNKNOWN:-} " == *" $p "* ]] && { echo "E: Unable to locate package $p"; exit 100; }
done
[ -n "${STUB_APT_FAIL:-}" ] && {
    echo "Err:1 http://deb.debian.org/debian bookworm/main amd64 cmake amd64 3.25.1-1"
    echo "E: Failed to fetch http://deb.debian.org/debian/pool/main/c/cmake/cmake_3.25.1-1_amd64.deb  404  Not Found"
    exit 100
}
echo "Setting up $*"
EOF
# npm ci ...: writes node_modules/webgpu/package.json, or fails as npm does when $STUB_NPM_FAIL is set.
cat >"$S/npm" <<'EOF'
#!/bin/bash
echo "npm $*" >>"$STUB_LOG"
[ -n "${STUB_NPM_FAIL:-}" ] && {
    echo "npm error code ECONNREFUSED"
    echo "npm error request to https://registry.npmjs.org/webgpu failed"
    exit 1
}
mkdir -p node_modules/webgpu && echo '{}' >node_modules/webgpu/package.json
EOF
printf '#!/bin/bash\necho "node $*" >>"$STUB_LOG"\n' >"$S/node"
# id -u: $STUB_UID (0 when unset); sudo runs its command, recorded.
printf '#!/bin/bash\n[ "$1" = -u ] && echo "${STUB_UID:-0}"\n' >"$S/id"
printf '#!/bin/bash\necho "sudo $*" >>"$STUB_LOG"\nexec "$@"\n' >"$S/sudo"
chmod +x "$S"/*

# stub_path DIR STUB...: a PATH directory of the stubs but those named, and links to the real tools deps.sh uses.
stub_path() {
    local dir=$1 f tool
    shift
    mkdir -p "$dir"
    for f in "$S"/*; do [[ " $* " == *" $(basename "$f") "* ]] || ln -s "$f" "$dir/"; done
    for tool in bash cat cut date grep mkdir rm sed sha256sum tail tee tr awk env; do
        ln -s "$(command -v $tool)" "$dir/"
    done
}
stub_path "$T/nosudo" sudo
stub_path "$T/nonode" node npm

# deps CASE-NAME SHELL-CODE: runs SHELL-CODE after sourcing deps.sh in a fresh bash under set -euo pipefail, with the
# stubs first on PATH, in $T/work (with a gpu/package-lock.json), logs in $T/logs. Keeps stdout/stderr in $T/out and
# $T/err, the stubs' calls in $T/calls, the status in $rc.
deps() {
    local name=$1 code=$2
    rm -rf "$T/work" "$T/logs" "$T/calls.updated" && mkdir -p "$T/work/gpu" "$T/logs" && : >"$T/calls"
    echo '{"lockfileVersion": 3}' >"$T/work/gpu/package-lock.json"
    (cd "$T/work" && PATH=${STUB_PATH:-$S:$PATH} STUB_LOG=$T/calls RTO_LOG_DIR=$T/logs \
        bash -c "set -euo pipefail; . '$DEPS'; $code; echo reached") >"$T/out" 2>"$T/err"
    rc=$?
    case_name=$name
}
want_rc() { [ "$rc" = "$1" ] || { fail "$case_name: exit $rc, want $1"; sed 's/^/    | /' "$T/err" | head; }; }
# want_calls PATTERN: the stubs' calls, one per line, match the extended regex exactly.
INSTALL='apt-get install -y -q --no-install-recommends'
want_calls() {
    local calls
    calls=$(grep -v '^dpkg-query ' "$T/calls" | tr '\n' '|')
    [[ $calls =~ ^$1$ ]] || fail "$case_name: calls '$calls', want /$1/"
}
# want_err REGEX: the failure is one line, the last, matching REGEX; before it at most the line announcing the install.
want_err() {
    tail -1 "$T/err" | grep -Eq -- "$1" && [ "$(grep -vc '^rtoracle: installing ' "$T/err")" = 1 ] ||
        { fail "$case_name: stderr does not end in the one line /$1/:"; sed 's/^/    | /' "$T/err" | head; }
}

# Every package deps.sh lists (cmake in the middle of the list, as the cases below expect).
ALL=$(bash -c ". '$DEPS'; echo \${RTO_DEBS[*]}")
[[ " $ALL " == *" cmake "* && " $ALL " == *" libcmocka-dev "* && " $ALL " != "build-essential "* ]] ||
    fail "RTO_DEBS no longer holds cmake and libcmocka-dev: $ALL"
export STUB_INSTALLED=$ALL

# Everything installed: one dpkg-query for the whole list, no apt-get, nothing printed, and the script goes on.
deps installed rto_install_deps
want_rc 0
want_calls ''
[ -s "$T/err" ] && fail "installed: printed $(head -1 "$T/err")"
has reached out
n=$(grep -c '^dpkg-query' "$T/calls")
[ "$n" = 1 ] || fail "installed: $n dpkg-query calls, want 1"

# Some missing (one never installed, one removed with its configuration left): exactly those installed, in the
# list's order, with one line before and one after.
MISSING2=${ALL/ cmake / }
STUB_INSTALLED=${MISSING2/ libcmocka-dev / } STUB_REMOVED=libcmocka-dev deps some-missing rto_install_deps
want_rc 0
want_calls "$INSTALL cmake libcmocka-dev\|"
has reached out
grep -q "installing 2 Debian packages: cmake libcmocka-dev (log: $T/logs/rtoracle-apt.log)" "$T/err" &&
    grep -q "installed 2 Debian packages in" "$T/err" && [ "$(wc -l <"$T/err")" = 2 ] ||
    { fail "some-missing: messages"; sed 's/^/    | /' "$T/err"; }

# Node.js missing as well: nodejs and npm join the list (a PATH with no node and no npm).
STUB_PATH=$T/nonode STUB_INSTALLED=${ALL/ cmake / } deps no-node rto_install_deps
want_rc 0
want_calls "$INSTALL cmake nodejs npm\|"

# The cached package lists are stale or absent: the first install fails, apt-get update, the second succeeds.
STUB_APT_STALE=1 STUB_INSTALLED=${ALL/ cmake / } deps fresh-lists rto_install_deps
want_rc 0
want_calls "$INSTALL cmake\|apt-get update -q\|$INSTALL cmake\|"
has reached out

# An unknown package name: both attempts fail; one line naming it and the log; status 1; the script stops.
STUB_UNKNOWN=no-such-package deps unknown 'rto_install_debs cmake no-such-package'
want_rc 1
want_calls "$INSTALL no-such-package\|apt-get update -q\|$INSTALL no-such-package\|"
want_err "^rtoracle: apt-get has no package 'no-such-package' .*; see $T/logs/rtoracle-apt.log\$"
grep -q reached "$T/out" && fail "unknown: the script went on after a failed install"

# apt-get failing (a fetch error): one line with apt's error and the log.
STUB_APT_FAIL=1 STUB_INSTALLED=${ALL/ cmake / } deps apt-fails rto_install_deps
want_rc 1
want_calls "$INSTALL cmake\|apt-get update -q\|$INSTALL cmake\|"
want_err "^rtoracle: apt-get failed installing cmake: E: Failed to fetch .*404  Not Found; see $T/logs/rtoracle-apt.log"

# Not root: apt-get through sudo; without sudo, one line and status 1, no apt-get.
STUB_UID=1000 STUB_INSTALLED=${ALL/ cmake / } deps sudo rto_install_deps
want_rc 0
want_calls "sudo $INSTALL cmake\|$INSTALL cmake\|"
STUB_PATH=$T/nosudo STUB_UID=1000 STUB_INSTALLED=${ALL/ cmake / } deps no-sudo rto_install_deps
want_rc 1
want_calls ''
want_err '^rtoracle: missing Debian packages cmake: run as root \(or install sudo\)$'

# npm: installed once, then kept while the lock is unchanged; a changed lock installs again.
deps npm 'rto_install_gpu_deps; rto_install_gpu_deps'
want_rc 0
want_calls 'npm ci --no-audit --no-fund --loglevel=error\|'
[ -f "$T/work/gpu/node_modules/.rto-lock.sha256" ] || fail "npm: no stamp written"
(cd "$T/work" && PATH=$S:$PATH STUB_LOG=$T/calls RTO_LOG_DIR=$T/logs bash -c "set -euo pipefail; . '$DEPS'
    echo '{\"lockfileVersion\": 3, \"changed\": 1}' >gpu/package-lock.json; rto_install_gpu_deps") 2>/dev/null ||
    fail "npm: a changed lock failed"
[ "$(grep -c '^npm ci' "$T/calls")" = 2 ] || fail "npm: a changed lock did not run npm ci again"

# npm failing: one line with npm's first error and the log; no stamp, so the next run tries again.
STUB_NPM_FAIL=1 deps npm-fails rto_install_gpu_deps
want_rc 1
want_calls 'npm ci --no-audit --no-fund --loglevel=error\|'
want_err "^rtoracle: npm ci failed in gpu/: npm error code ECONNREFUSED; see $T/logs/rtoracle-npm.log\$"
[ -f "$T/work/gpu/node_modules/.rto-lock.sha256" ] && fail "npm-fails: a stamp was written"

finish "scripts.deps: installed, some missing, no node, stale lists, unknown package, apt and npm failing, sudo"
