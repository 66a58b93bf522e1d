#!/usr/bin/env bash
# `meson install` of a build into a scratch prefix, then a user's program (tests/install_consumer.c) built against the
# installed copy through pkg-config — as C, as C++, and statically — and run; and one that writes and reads back every
# bundle kind (tests/install_bundles.c).
#   bash tests/install.sh BUILDDIR
set -u
B=$1
. "$(dirname "$0")/cli_lib.sh"
SRC=$(cd "$(dirname "$0")" && pwd)
meson install -C "$B" --destdir "$T/root" --no-rebuild --quiet >"$T/install.log" 2>&1 ||
    { fail "meson install"; sed 's/^/    | /' "$T/install.log" | tail; finish ""; }
prefix=$(meson introspect "$B" --buildoptions | python3 -c 'import json,sys; print([o["value"] for o in json.load(sys.stdin) if o["name"]=="prefix"][0])')
root=$T/root$prefix
pc=$(find "$root" -name rtoracle.pc | head -1)
[ -n "$pc" ] || { fail "rtoracle.pc not installed"; finish ""; }
[ -x "$root/bin/rtoracle" ] || fail "rtoracle command not installed"
[ -f "$root/include/rtoracle.h" ] || fail "rtoracle.h not installed"
export PKG_CONFIG_PATH=$(dirname "$pc")
pcf() { pkg-config --define-variable=prefix="$root" "$@" rtoracle; }
libdir=$(pcf --variable=libdir)
run 0 cc -std=c11 -Wall -Werror $(pcf --cflags) "$SRC/install_consumer.c" -o "$T/c" $(pcf --libs) &&
    LD_LIBRARY_PATH=$libdir run 0 "$T/c" && has "fault order at slot 100" out
run 0 c++ -x c++ -std=c++17 -Wall -Werror $(pcf --cflags) "$SRC/install_consumer.c" -o "$T/cxx" $(pcf --libs) &&
    LD_LIBRARY_PATH=$libdir run 0 "$T/cxx"
run 0 cc -std=c11 $(pcf --cflags) "$SRC/install_consumer.c" -o "$T/static" \
    "$libdir/librtoracle.a" $(pcf --static --libs-only-l | sed 's/-lrtoracle//') && run 0 "$T/static"
# Every bundle kind written and read back through the installed library, as C and as C++ (tests/install_bundles.c).
run 0 cc -std=c11 -Wall -Werror $(pcf --cflags) "$SRC/install_bundles.c" -o "$T/bundles" $(pcf --libs) &&
    mkdir -p "$T/b1" && LD_LIBRARY_PATH=$libdir run 0 "$T/bundles" "$T/b1" &&
    has "^sort bitonic: written, read back" out && has "^sort radix: written, read back" out &&
    has "^build: TLAS and BLAS 0" out && has "^trace: 192 rays written and read back" out && has "^frame: " out
run 0 c++ -x c++ -std=c++17 -Wall -Werror $(pcf --cflags) "$SRC/install_bundles.c" -o "$T/bundles_cxx" $(pcf --libs) &&
    mkdir -p "$T/b2" && LD_LIBRARY_PATH=$libdir run 0 "$T/bundles_cxx" "$T/b2"
# The shared library exports the public API only: every exported symbol is declared in the installed header.
nm -D --defined-only "$libdir/librtoracle.so" | awk '{print $3}' | while read -r sym; do
    grep -qw -- "$sym" "$root/include/rtoracle.h" || echo "$sym"
done | head -5 >"$T/extra"
[ -s "$T/extra" ] && fail "librtoracle.so exports symbols the header does not declare: $(tr '\n' ' ' <"$T/extra")"
LD_LIBRARY_PATH=$libdir run 0 "$root/bin/rtoracle" --version && has rtoracle out

# The command does not link Embree (crosscheck loads the module librto_embree.so on demand), and an installed tree
# copied to another prefix uses its own modules: the image module for check-frame and compare, Embree's for crosscheck.
ldd "$root/bin/rtoracle" | grep -qi embree && fail "the installed rtoracle links Embree"
[ -f "$libdir/rtoracle/librto_embree.so" ] && [ -f "$libdir/rtoracle/librto_image.so" ] ||
    fail "the modules are not installed in $libdir/rtoracle"
cp -a "$root" "$T/moved"
moved_lib=$T/moved/${libdir#"$root"/}
# loaded LIB ARGS...: the moved rtoracle runs ARGS, and the dynamic loader opened LIB from the moved tree
loaded() {
    local lib=$1
    shift
    LD_LIBRARY_PATH=$moved_lib LD_DEBUG=files run 0 "$T/moved/bin/rtoracle" "$@" &&
        grep -q "file=$T/moved/.*rtoracle/$lib" "$T/err" ||
        { fail "the moved rtoracle $1 did not load its own $lib"; grep "$lib" "$T/err" | head -3 | sed 's/^/    | /'; }
}
printf 'P3\n2 1\n255\n0 0 0 255 255 255\n' >"$T/a.ppm"
loaded librto_image.so compare "$T/a.ppm" "$T/a.ppm"
loaded librto_embree.so crosscheck triangle --count 16 --width 4 --height 4 --threads 1
finish "install: rtoracle, librtoracle (.so, .a), rtoracle.h, rtoracle.pc and the two modules installed; a pkg-config build links and runs; a copied tree uses its own modules"
