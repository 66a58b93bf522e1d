# Sourced by main.sh and test.sh: installs the Debian packages the build needs, only those missing, quietly.
# Works as root on a fresh Debian 12; as another user it uses sudo when present.

RTO_DEBS=(
    build-essential pkg-config meson ninja-build   # toolchain
    libjansson-dev libssl-dev                      # manifest.json (jansson), sha256 (libcrypto)
    libcmocka-dev                                  # unit tests
    g++ libtinygltf-dev nlohmann-json3-dev         # glTF scenes: tinygltf (header-only use) and its JSON parser
    libopenimageio-dev libpng-dev                  # glTF textures (decoded in the librto_image.so module)
    libembree-dev                                  # benchmarks: Embree on the same geometry
    assimp-testmodels                              # glTF 2.0 test files, broken ones included (tests only)
    libegl1 libgles2 libegl-mesa0 libgl1-mesa-dri  # gpu/: Dawn's OpenGL backend on Mesa llvmpipe (no GPU needed)
)

rto_install_deps() {
    local extra=()
    # gpu/ runs on Node.js (Debian 12 ships 18; a newer one already installed is kept).
    if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
        extra+=(nodejs npm)
    fi
    rto_install_debs "${RTO_DEBS[@]}" "${extra[@]}"
}

# Installs those of the named Debian packages that are missing (also used by scripts/bench-plot for its plotting).
rto_install_debs() {
    local missing=() installed p
    # One dpkg-query for the whole list (one per package takes seconds on a busy machine).
    installed=" $(dpkg-query -W -f='${db:Status-Abbrev}${Package} ' "$@" 2>/dev/null | tr -s ' ' | sed 's/ii \([^ ]*\)/+\1/g') "
    for p in "$@"; do
        [[ $installed == *" +$p "* ]] || missing+=("$p")
    done
    [ ${#missing[@]} -eq 0 ] && return 0
    local sudo=""
    if [ "$(id -u)" != 0 ]; then
        command -v sudo >/dev/null || { echo "rtoracle: missing packages ${missing[*]}; run as root" >&2; return 1; }
        sudo="sudo"
    fi
    echo "rtoracle: installing ${missing[*]}" >&2
    export DEBIAN_FRONTEND=noninteractive
    # Refresh the package lists only when an install from the cached lists fails (a fresh image has none).
    $sudo apt-get install -y -q --no-install-recommends "${missing[@]}" >/tmp/rtoracle-apt.log 2>&1 || {
        $sudo apt-get update -q >>/tmp/rtoracle-apt.log 2>&1 &&
            $sudo apt-get install -y -q --no-install-recommends "${missing[@]}" >>/tmp/rtoracle-apt.log 2>&1
    } || { echo "rtoracle: apt-get failed, see /tmp/rtoracle-apt.log" >&2; tail -20 /tmp/rtoracle-apt.log >&2; return 1; }
}

# meson setup (once) and compile of one build directory: rto_build DIR [meson options...]
rto_build() {
    local dir=$1
    shift
    if [ ! -f "$dir/build.ninja" ]; then
        meson setup "$dir" "$@" >"$dir.setup.log" 2>&1 || { cat "$dir.setup.log" >&2; return 1; }
        rm -f "$dir.setup.log"
    fi
    local log
    log=$(ninja -C "$dir" 2>&1) || { printf '%s\n' "$log" >&2; return 1; }
}

# gpu/'s npm dependencies, pinned by gpu/package-lock.json: installed once (npm ci), kept while the lock is unchanged.
rto_install_gpu_deps() {
    local stamp=gpu/node_modules/.rto-lock.sha256 want
    want=$(sha256sum gpu/package-lock.json | cut -d' ' -f1)
    [ -f gpu/node_modules/webgpu/package.json ] && [ "$(cat "$stamp" 2>/dev/null)" = "$want" ] && return 0
    echo "rtoracle: installing gpu/'s npm packages (npm ci)" >&2
    (cd gpu && npm ci --no-audit --no-fund --loglevel=error >/tmp/rtoracle-npm.log 2>&1) ||
        { echo "rtoracle: npm ci failed, see /tmp/rtoracle-npm.log" >&2; tail -20 /tmp/rtoracle-npm.log >&2; return 1; }
    echo "$want" >"$stamp"
}
