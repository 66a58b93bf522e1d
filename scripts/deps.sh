# Sourced by main.sh, test.sh and bench-plot: installs the Debian packages and npm packages the build needs (only those
# missing, saying what it installs), and builds a build directory with one progress line.
# Works as root from a brand-new Debian 12 minbase root; as another user it uses sudo when present. Every failure is
# one line naming what failed and the log to read, and a non-zero status (tests/scripts_deps.sh holds it to that with
# dpkg-query, apt-get and npm replaced by stubs).

RTO_DEBS=(
    build-essential pkg-config meson ninja-build   # toolchain
    cmake                                          # meson finds Embree through its CMake package (libembree-dev)
    libjansson-dev libssl-dev                      # manifest.json (jansson), sha256 (libcrypto)
    libcmocka-dev                                  # unit tests
    g++ libtinygltf-dev nlohmann-json3-dev         # glTF scenes: tinygltf (header-only use) and its JSON parser
    libopenimageio-dev libpng-dev                  # images: PNG written by libpng, the rest in librto_image.so
    libembree-dev                                  # benchmarks: Embree on the same geometry
    assimp-testmodels                              # glTF 2.0 test files, broken ones included (tests only)
    strace                                         # tests: a final swap held up in the kernel (cli.signals)
    libegl1 libgles2 libegl-mesa0 libgl1-mesa-dri  # gpu/: Dawn's OpenGL backend on Mesa llvmpipe (no GPU needed)
    libegl-dev                                     # gpu/: Dawn opens the unversioned libEGL.so, which only this ships
)

# What the test command needs besides: clang, whose libFuzzer the sanitizer build's fuzz targets link, its linker,
# llvm-14's llvm-symbolizer, which names the functions in the sanitizers' reports (scripts/test.sh), and Debian's
# idiff, which cli.compare holds compare's exit statuses to.
RTO_TEST_DEBS=(clang-14 libclang-rt-14-dev lld-14 llvm-14 openimageio-tools)

# Where the apt and npm logs go (one file each, rewritten by every install).
RTO_LOG_DIR=${RTO_LOG_DIR:-${TMPDIR:-/tmp}}

rto_say() { echo "rtoracle: $*" >&2; }

rto_install_deps() {
    local extra=()
    # gpu/ runs on Node.js (Debian 12 ships 18; a newer one already installed is kept).
    if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
        extra+=(nodejs npm)
    fi
    rto_install_debs "${RTO_DEBS[@]}" "${extra[@]}"
}

# Prints, one per line, those of the named Debian packages that are not fully installed.
rto_missing_debs() {
    local status
    # One dpkg-query for the whole list (one per package takes seconds on a busy machine). It exits 1 when any name
    # is not installed or unknown, which is the ordinary case here, not an error: its output says which are installed.
    status=$(dpkg-query -W -f='${db:Status-Abbrev} ${Package}\n' "$@" 2>/dev/null) || true
    local -A ok=()
    local abbrev name p
    while read -r abbrev name; do
        [ "$abbrev" = ii ] && ok[$name]=1
    done <<<"$status"
    for p in "$@"; do
        [ -n "${ok[$p]:-}" ] || echo "$p"
    done
}

# Installs those of the named Debian packages that are missing; says which, and how long it took.
rto_install_debs() {
    local missing=()
    mapfile -t missing < <(rto_missing_debs "$@")
    [ ${#missing[@]} -eq 0 ] && return 0
    local sudo=() log=$RTO_LOG_DIR/rtoracle-apt.log
    if [ "$(id -u)" != 0 ]; then
        command -v sudo >/dev/null ||
            { rto_say "missing Debian packages ${missing[*]}: run as root (or install sudo)"; return 1; }
        sudo=(sudo)
    fi
    local what="${#missing[@]} Debian packages"
    [ ${#missing[@]} = 1 ] && what="1 Debian package"
    rto_say "installing $what: ${missing[*]} (log: $log)"
    local t0=$SECONDS
    export DEBIAN_FRONTEND=noninteractive
    # Refresh the package lists only when an install from the cached lists fails (a fresh image has none).
    if ! "${sudo[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}" >"$log" 2>&1; then
        if ! "${sudo[@]}" apt-get update -q >>"$log" 2>&1 ||
            ! "${sudo[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}" >>"$log" 2>&1; then
            rto_say "$(rto_apt_failure "$log" "${missing[@]}")"
            return 1
        fi
    fi
    rto_say "installed $what in $((SECONDS - t0)) s"
}

# The one line that says why apt-get failed: the package it does not know, or its last error, and the log.
rto_apt_failure() {
    local log=$1 p
    shift
    # apt names an unknown package in one of these two forms; only the last attempt's lines count.
    for p in "$@"; do
        if grep -qE "^E: (Unable to locate package $p\$|Package '$p' has no installation candidate)" "$log"; then
            echo "apt-get has no package '$p' (is this Debian 12 with its main archive?); see $log"
            return
        fi
    done
    local err
    err=$(grep -E '^(E|Err):' "$log" | tail -1)
    echo "apt-get failed installing ${*}${err:+: $err}; see $log"
}

# gpu/'s npm dependencies, pinned by gpu/package-lock.json: installed once (npm ci), kept while the lock is unchanged.
rto_install_gpu_deps() {
    local stamp=gpu/node_modules/.rto-lock.sha256 want log=$RTO_LOG_DIR/rtoracle-npm.log
    want=$(sha256sum gpu/package-lock.json | cut -d' ' -f1)
    [ -f gpu/node_modules/webgpu/package.json ] && [ "$(cat "$stamp" 2>/dev/null)" = "$want" ] && return 0
    rto_say "installing gpu/'s npm packages with npm ci (log: $log)"
    local t0=$SECONDS
    if ! (cd gpu && npm ci --no-audit --no-fund --loglevel=error >"$log" 2>&1); then
        local err
        err=$(grep -E 'npm (ERR!|error)' "$log" | head -1)
        rto_say "npm ci failed in gpu/${err:+: $err}; see $log"
        return 1
    fi
    echo "$want" >"$stamp"
    rto_say "installed gpu/'s npm packages in $((SECONDS - t0)) s"
}

# meson setup (once) and compile of one build directory: rto_build DIR [meson options...] [-- installed]
# (everything, or with "-- installed" only what `meson install` installs). Compiling prints one line that grows by tens of percent
# ("compiling build: 10% 20% ... 100% (133 steps, 44 s)"); an up-to-date directory prints nothing. A failure prints
# the compiler's output.
rto_build() {
    local dir=$1 opts=() targets=()
    shift
    while [ $# -gt 0 ] && [ "$1" != -- ]; do opts+=("$1") && shift; done
    local log=$dir.log
    if [ ! -f "$dir/build.ninja" ]; then
        rto_say "configuring $dir (meson setup ${opts[*]})"
        meson setup "$dir" "${opts[@]}" >"$log" 2>&1 || { cat "$log" >&2; rm -f "$log"; return 1; }
    fi
    if [ "${2:-}" = installed ]; then
        mapfile -t targets < <(meson introspect "$dir" --targets | python3 -c '
import json, os, sys
for t in json.load(sys.stdin):
    if t["installed"]:
        print("\n".join(os.path.relpath(f, sys.argv[1]) for f in t["filename"]))' "$dir")
    fi
    local status
    NINJA_STATUS='@@%f/%t@@ ' ninja -C "$dir" "${targets[@]}" 2>&1 | tee "$log" |
        awk -v dir="$dir" -v t0="$(date +%s)" '
            match($0, /^@@[0-9]+\/[0-9]+@@/) {
                split(substr($0, 3, RLENGTH - 4), ft, "/")
                if (!shown) { printf "rtoracle: compiling %s:", dir > "/dev/stderr"; shown = 1 }
                pct = int(ft[1] * 10 / ft[2]) * 10
                if (pct > last) { printf " %d%%", pct > "/dev/stderr"; fflush("/dev/stderr"); last = pct }
                steps = ft[2]
            }
            # srand() returns the previous seed, and srand() without an argument seeds with the time of day.
            END { if (shown) { srand(); printf " (%d steps, %d s)\n", steps, srand() - t0 > "/dev/stderr" } }'
    status=${PIPESTATUS[0]}
    if [ "$status" != 0 ]; then
        sed -E 's/^@@[0-9]+\/[0-9]+@@ //' "$log" >&2
        rto_say "compiling $dir failed (status $status); the full output is above and in $log"
        return 1
    fi
    rm -f "$log"
}

# rto_render_settings FIXTURE PROGRAM: the arguments fixtures/render-settings.txt gives `rtoracle render` for a
# fixture (a path under fixtures/) and a program, one per line; nothing when it has none.
rto_render_settings() {
    local rel=${1#fixtures/}
    awk -v f="$rel" -v p="$2" '!/^#/ && $1 == f && $2 == p { for (i = 3; i <= NF; i++) print $i }' \
        fixtures/render-settings.txt
}
