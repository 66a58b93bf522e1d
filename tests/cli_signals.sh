#!/usr/bin/env bash
# Stop signals at any moment and on any thread: `suite sort` and `render` replacing an existing bundle get SIGINT
# after varying delays, sent to each of their threads in turn (tgkill), and once while the final swap is held up in
# the kernel (strace delays renameat2). Every interrupted run must end with status 130, its destination must be the
# old bundle or the new one, byte for byte, and no temporary may be left beside it.
#   bash tests/cli_signals.sh RTORACLE TGKILL
set -u
RTO=$1
TGK=$2
. "$(dirname "$0")/cli_lib.sh"
# A background job of a shell without job control starts with SIGINT ignored, as POSIX asks, and a program keeps
# an ignored SIGINT ignored: env gives it back its default action.
bg=(env --default-signal=INT)

suite=(suite sort --sizes tiny,tile --dists random,one-bucket --checkpoint-max 4096)
render=(render rtstress:3 --program sun-shadow --height 120 --stages all)
"$RTO" "${suite[@]}" --seed 1 -o "$T/suite-old" >/dev/null || fail "suite sort (old)"
"$RTO" "${suite[@]}" --seed 2 -o "$T/suite-new" >/dev/null || fail "suite sort (new)"
"$RTO" "${render[@]}" --width 128 -o "$T/render-old" >/dev/null || fail "render (old)"
"$RTO" "${render[@]}" --width 160 -o "$T/render-new" >/dev/null || fail "render (new)"

# settled NAME STATUS: the destination $T/d is the old or the new bundle, whole, and nothing else is left beside it.
settled() {
    local name=$1 rc=$2
    if diff -r "$T/d" "$T/$name-old" >/dev/null 2>&1; then
        echo old
    elif diff -r "$T/d" "$T/$name-new" >/dev/null 2>&1; then
        echo new
    else
        fail "$name: exit $rc left $T/d neither the old bundle nor the new one: $(ls "$T/d" 2>&1 | head -3 | tr '\n' ' ')"
        echo broken
    fi
    local left
    left=$(cd "$T" && ls -d d.tmp.* 2>/dev/null | head -3 | tr '\n' ' ')
    [ -z "$left" ] || fail "$name: exit $rc left temporaries: $left"
    rm -rf "$T"/d.tmp.*
}

# trials NAME ARGS...: 12 runs (3 under the sanitizers), SIGINT after 0-220 ms to thread (i mod threads) of the
# process.
trials() {
    local name=$1 i rc pid tasks tid stopped=0 finished=0
    shift
    for ((i = 0; i < 24; i += 2 * $(sampled 4))); do
        rm -rf "$T/d" && cp -a "$T/$name-old" "$T/d"
        "${bg[@]}" "$RTO" "$@" --force -o "$T/d" >/dev/null 2>"$T/err" &
        pid=$!
        # The signal is for the program, not for the shell's copy of itself that has yet to exec it (bash runs its
        # EXIT trap there on SIGINT): wait for the exec.
        while [ /proc/$pid/exe -ef "$BASH" ]; do :; done
        sleep "0.$(printf '%03d' $((i * 10)))"
        tasks=(/proc/$pid/task/*)
        tid=${tasks[$((i % ${#tasks[@]}))]##*/}
        "$TGK" "$pid" "$tid" 2 2>/dev/null
        wait "$pid"
        rc=$?
        case $rc in
        130) stopped=$((stopped + 1)) ;;
        0) finished=$((finished + 1)) ;; # done before the signal came
        *) fail "$name: trial $i (SIGINT to thread $tid of ${#tasks[@]} after $((i * 10)) ms): exit $rc: $(head -c 300 "$T/err")" ;;
        esac
        [ "$(settled "$name" "$rc")" = new ] || [ "$rc" != 0 ] || fail "$name: exit 0 but the old bundle is in place"
    done
    [ "$stopped" -ge $((4 / $(sampled 4))) ] ||
        fail "$name: only $stopped runs were stopped by the signal (the delays are too long?)"
    echo "$name: $stopped runs stopped (status 130), $finished finished first; every destination whole, no temporary left"
}
trials suite "${suite[@]}" --seed 2
trials render "${render[@]}" --width 160

# The final swap held up 1 s in the kernel (the exchange of the new bundle with the old one), and SIGINT
# meanwhile, to the process (as a terminal sends it) and to the thread created last: the swap completes, then the
# signal ends the run.
if [ "$(uname -m)" = x86_64 ] && command -v strace >/dev/null; then
    # swap_case NAME TO ARGS...: one run; status 3 when the swap was never seen held up (the run ended first).
    swap_case() {
        local name=$1 to=$2 spid pid= tasks tid rc
        shift 2
        rm -rf "$T/d" && cp -a "$T/$name-old" "$T/d"
        # LeakSanitizer cannot run under ptrace; the sanitizer build skips only its leak check here.
        ASAN_OPTIONS=${ASAN_OPTIONS:-}:detect_leaks=0 "${bg[@]}" strace -f -o /dev/null -e trace=renameat2 \
            -e inject=renameat2:delay_enter=1000000 "$RTO" "$@" --force -o "$T/d" >/dev/null 2>"$T/err" &
        spid=$!
        # The tracee is strace's child; wait until one of its threads is inside renameat2 (x86_64: 316), which
        # only the final exchange calls.
        while kill -0 "$spid" 2>/dev/null; do
            pid=${pid:-$(cat /proc/$spid/task/*/children 2>/dev/null | awk '{print $1}')}
            [ -n "$pid" ] && grep -qs '^316 ' /proc/"$pid"/task/*/syscall && break
            sleep 0.01
        done
        tasks=(/proc/$pid/task/*)
        tid=${tasks[-1]##*/}
        if ! [ -n "$pid" ] || ! { if [ $to = process ]; then kill -INT "$pid"; else "$TGK" "$pid" "$tid" 2; fi; } 2>/dev/null
        then
            wait "$spid"
            return 3
        fi
        wait "$spid"
        rc=$?
        [ "$rc" = 130 ] || fail "$name: SIGINT to the $to during the delayed swap: exit $rc: $(head -c 300 "$T/err")"
        [ "$(settled "$name" "$rc")" = new ] || fail "$name: SIGINT to the $to: the swap under way did not complete"
    }
    for name in suite render; do
        if [ $name = suite ]; then args=("${suite[@]}" --seed 2); else args=("${render[@]}" --width 160); fi
        for to in process thread; do
            # A loaded machine can run the whole swap between two looks: up to ten tries.
            for try in 1 2 3 4 5 6 7 8 9 10; do
                swap_case $name $to "${args[@]}" && break
                [ $try = 10 ] && fail "$name: the delayed swap was never seen in 10 runs"
            done
        done
    done
    echo "delayed swap: SIGINT to the process or a thread while renameat2 is held up ends 130, the new bundle in place"
else
    echo "delayed swap: not run (needs strace on x86_64)"
fi
# SIGKILL leaves a temporary behind (nothing can run); the next run for the same destination removes it, and the
# abandoned temporaries named like ours whose process is gone, but not a live process's, another name, or a stranger's.
rm -rf "$T"/k "$T"/k.tmp.*
"${bg[@]}" "$RTO" "${suite[@]}" --seed 3 -o "$T/k" >/dev/null 2>&1 &
pid=$!
for ((w = 0; w < 500; w++)); do
    compgen -G "$T/k.tmp.$pid-*" >/dev/null && break
    sleep 0.01
done
kill -KILL "$pid"
wait "$pid" 2>/dev/null
compgen -G "$T/k.tmp.$pid-*" >/dev/null || fail "SIGKILL: no temporary was seen (the run ended first?)"
dead=$(sh -c 'echo $$')
mkdir "$T/k.tmp.$dead-ABCdef~" "$T/k.tmp.$$-ABCdef" "$T/k.tmp.abcdef" "$T/k.tmp.$dead-ABC"
run 0 "$RTO" "${suite[@]}" --seed 3 -o "$T/k"
left=$(cd "$T" && ls -d k.tmp.* | sort | tr '\n' ' ')
want=$(printf '%s\n' "k.tmp.$$-ABCdef" "k.tmp.$dead-ABC" k.tmp.abcdef | sort | tr '\n' ' ')
[ "$left" = "$want" ] || fail "after a SIGKILL and a new run: left '$left', want '$want'"
echo "SIGKILL: the next run removed the killed run's temporary and an abandoned one, kept a live one and strangers"

finish "signals: every stopped run left the old or the new bundle, whole, and no temporary"
