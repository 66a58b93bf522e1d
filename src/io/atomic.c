/* Atomic output (DESIGN.md §8): every file or bundle directory is written under a temporary sibling name
 * (`TARGET.tmp.PID-XXXXXX`) and renamed into place, so a reader never sees half an output and a failed run never leaves
 * one behind. This file owns the three rules every writer shares:
 *
 *  - Temporary names are created with mkdir(0777) / open(0666), so the process umask (and a default ACL) applies
 *    exactly as it would to a plain `mkdir` or `>` redirection; mkdtemp / mkstemp would force 0700 / 0600.
 *  - Every temporary in existence is listed in a fixed-size registry that a SIGINT / SIGTERM handler can walk with
 *    async-signal-safe calls only (rto_temporaries_remove), so an interrupted run leaves no `*.tmp.*` behind.
 *    Creation + registration and rename + deregistration run with those signals blocked, so the handler never sees
 *    a temporary that is not listed, nor a listed name that already holds the finished output.
 *  - A target that is not a regular file is never replaced: a symbolic link is followed (its target is replaced,
 *    the link stays), a directory or device is refused. */
#define _GNU_SOURCE /* O_DIRECTORY, O_NOFOLLOW, O_CLOEXEC, SYS_getdents64 */
#include "io_internal.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

/* ---------------------------------------------------------------------------------------------------------------- */
/* The registry. Slots hold the path itself (no pointer a handler could find freed). A slot is FREE, being FILLED,
 * or LIVE; only LIVE slots are removed by the handler. 32 slots cover the deepest nesting a writer uses (suite
 * directory, case directory, one .npy) many times over; a temporary that finds no slot is still written and
 * renamed as usual, it just is not cleaned up on a signal. */

#define TMP_SLOTS 32
enum { SLOT_FREE, SLOT_FILLING, SLOT_LIVE };

static struct {
    atomic_int state;
    char path[PATH_MAX];
} g_slots[TMP_SLOTS];

/* Slots are keyed by the path as the writer names it; the handler removes the absolute path kept beside it, so a
 * later chdir by the program does not point it at the wrong place. */
static char g_keys[TMP_SLOTS][PATH_MAX];

static void registry_add(const char *path)
{
    size_t len = strlen(path), pre = 0;
    char cwd[PATH_MAX];
    if (path[0] != '/') {
        if (!getcwd(cwd, sizeof cwd))
            return;
        pre = strlen(cwd) + 1;
    }
    if (len >= PATH_MAX || pre + len >= PATH_MAX)
        return;
    for (int i = 0; i < TMP_SLOTS; i++) {
        int expected = SLOT_FREE;
        if (atomic_compare_exchange_strong(&g_slots[i].state, &expected, SLOT_FILLING)) {
            if (pre) {
                memcpy(g_slots[i].path, cwd, pre - 1);
                g_slots[i].path[pre - 1] = '/';
            }
            memcpy(g_slots[i].path + pre, path, len + 1);
            memcpy(g_keys[i], path, len + 1);
            atomic_store(&g_slots[i].state, SLOT_LIVE);
            return;
        }
    }
}

static void registry_remove(const char *path)
{
    for (int i = 0; i < TMP_SLOTS; i++) {
        int expected = SLOT_LIVE;
        if (atomic_load(&g_slots[i].state) == SLOT_LIVE && strcmp(g_keys[i], path) == 0 &&
            atomic_compare_exchange_strong(&g_slots[i].state, &expected, SLOT_FILLING)) {
            atomic_store(&g_slots[i].state, SLOT_FREE);
            return;
        }
    }
}

/* The signals whose default action ends the process and that a user sends to stop a run. */
static void stop_signals(sigset_t *set)
{
    sigemptyset(set);
    sigaddset(set, SIGINT);
    sigaddset(set, SIGTERM);
    sigaddset(set, SIGHUP);
}

/* A stop signal may be taken by any thread (a process-directed signal goes to any thread that does not block it, and
 * tgkill names one), also while another thread is creating, renaming or exchanging an output. So the moments and the
 * stop exclude each other through one counter: g_guard counts the threads inside a moment, and a stop claims the
 * process by turning 0 into -1. A stop that finds a moment in progress leaves its signal in g_deferred, and the
 * thread that ends the last moment carries it out. A thread that wants to begin a moment after the claim waits
 * until the process ends. */
static atomic_int g_guard;
static atomic_int g_deferred;

void rto__signals_hold(sigset_t *old)
{
    sigset_t set;
    stop_signals(&set);
    /* The handler then never runs on this thread inside the moment (it would only defer itself). */
    pthread_sigmask(SIG_BLOCK, &set, old);
    for (;;) {
        int v = atomic_load(&g_guard);
        if (v < 0) {
            /* The process is being stopped by another thread, which removes the temporaries and ends it. */
            const struct timespec ms = {0, 1000000};
            nanosleep(&ms, NULL);
            continue;
        }
        if (atomic_compare_exchange_weak(&g_guard, &v, v + 1))
            return;
    }
}

/* Removes every temporary and ends the process by sig's default action. Async-signal-safe. */
static _Noreturn void stop_now(int sig)
{
    rto_temporaries_remove();
    signal(sig, SIG_DFL);
    sigset_t one;
    sigemptyset(&one);
    sigaddset(&one, sig);
    sigprocmask(SIG_UNBLOCK, &one, NULL); /* this thread's mask on Linux, as pthread_sigmask */
    raise(sig);
    _exit(128 + sig); /* not reached: sig's default action ends the process */
}

void rto__signals_release(const sigset_t *old)
{
    int sig = 0, zero = 0;
    if (atomic_fetch_sub(&g_guard, 1) == 1 && (sig = atomic_load(&g_deferred)) != 0 &&
        atomic_compare_exchange_strong(&g_guard, &zero, -1))
        stop_now(sig);
    pthread_sigmask(SIG_SETMASK, old, NULL);
}

void rto_stop_signal(int sig)
{
    /* Deferred first, then the claim: a moment that ends between the two sees the signal and carries it out. */
    int zero = 0;
    atomic_store(&g_deferred, sig);
    if (atomic_compare_exchange_strong(&g_guard, &zero, -1))
        stop_now(sig);
}

void rto_stop_settle(void)
{
    if (atomic_load(&g_guard) < 0 || atomic_load(&g_deferred) != 0) {
        /* A stop is under way on another thread, or deferred to a moment that is still running: its signal, not
         * this thread's exit status, ends the process. */
        sigset_t set;
        stop_signals(&set);
        pthread_sigmask(SIG_UNBLOCK, &set, NULL);
        for (;;)
            pause();
    }
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Removal from a signal handler: openat / getdents64 / unlinkat / close only (no opendir, no malloc, no stdio). */

struct dirent64_raw {
    uint64_t d_ino;
    int64_t d_off;
    unsigned short d_reclen;
    unsigned char d_type;
    char d_name[];
};

/* Our temporaries nest three deep at most (suite / case / file); the limit only bounds the stack. */
#define REMOVE_DEPTH_MAX 8

static void remove_at(int parent, const char *name, int depth)
{
    if (unlinkat(parent, name, 0) == 0 || errno == ENOENT)
        return;
    if (depth >= REMOVE_DEPTH_MAX)
        return;
    int fd = openat(parent, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0)
        return;
    /* Entries are removed while the directory is read; a second sweep from the start catches any a filesystem's
     * readdir cursor skipped. */
    for (int sweep = 0; sweep < 3; sweep++) {
        _Alignas(8) char buf[2048];
        long got;
        while ((got = syscall(SYS_getdents64, fd, buf, sizeof buf)) > 0) {
            for (long off = 0; off < got;) {
                const struct dirent64_raw *e = (const struct dirent64_raw *)(buf + off);
                off += e->d_reclen;
                if (strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0)
                    remove_at(fd, e->d_name, depth + 1);
            }
        }
        if (unlinkat(parent, name, AT_REMOVEDIR) == 0 || errno != ENOTEMPTY)
            break;
        lseek(fd, 0, SEEK_SET);
    }
    close(fd);
}

void rto_temporaries_remove(void)
{
    int saved = errno;
    for (int i = 0; i < TMP_SLOTS; i++) {
        if (atomic_load(&g_slots[i].state) != SLOT_LIVE)
            continue;
        /* Moved aside first ("NAME~"): another thread still writing into it by name (a stop does not halt the other
         * threads) can then add no entry behind the sweep's back. */
        const char *path = g_slots[i].path;
        char aside[PATH_MAX];
        size_t n = strlen(path);
        if (n + 2 <= sizeof aside) {
            memcpy(aside, path, n);
            memcpy(aside + n, "~", 2);
            if (rename(path, aside) == 0)
                path = aside;
        }
        remove_at(AT_FDCWD, path, 0);
    }
    errno = saved;
}

/* ---------------------------------------------------------------------------------------------------------------- */

/* Six characters of [0-9A-Za-z] from a counter, the pid and the clock: names differ between tries and processes;
 * O_EXCL, not the name, is what makes creation safe. */
static void random_suffix(char out[7])
{
    static const char alphabet[] = "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz";
    static atomic_uint counter;
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    uint32_t x = rto_hash32(atomic_fetch_add(&counter, 1) ^ rto_hash32((uint32_t)getpid()) ^
                            rto_hash32((uint32_t)ts.tv_nsec ^ (uint32_t)ts.tv_sec));
    uint32_t y = rto_hash32(x ^ 0x9e3779b9u);
    for (int i = 0; i < 6; i++) {
        out[i] = alphabet[(i < 3 ? x : y) % 62];
        if (i < 3)
            x /= 62;
        else
            y /= 62;
    }
    out[6] = '\0';
}

/* The temporaries of target that a killed run left (SIGKILL, a crash, a power cut): names target.tmp.PID-XXXXXX (or
 * with the "~" of one moved aside) whose PID no longer lives here, owned by us. Anything else — another name, a
 * live PID, another owner — is left alone. A temporary made in another PID namespace that shares this directory
 * could look abandoned; such sharing is not supported. */
static void remove_stale(const char *target)
{
    const char *slash = strrchr(target, '/');
    const char *base = slash ? slash + 1 : target;
    char *dir = slash ? strndup(target, slash == target ? 1 : (size_t)(slash - target)) : strdup(".");
    DIR *d = dir ? opendir(dir) : NULL;
    free(dir);
    if (!d)
        return;
    const size_t blen = strlen(base);
    const pid_t self = getpid();
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        const char *n = e->d_name;
        if (strncmp(n, base, blen) != 0 || strncmp(n + blen, ".tmp.", 5) != 0)
            continue;
        char *end;
        errno = 0;
        const long pid = strtol(n + blen + 5, &end, 10);
        if (errno || pid <= 0 || end == n + blen + 5 || *end != '-' || strspn(end + 1, "0123456789ABCDEFGHIJKLMNOPQ"
            "RSTUVWXYZabcdefghijklmnopqrstuvwxyz") != 6 || (end[7] != '\0' && strcmp(end + 7, "~") != 0))
            continue;
        struct stat st;
        if ((pid_t)pid == self || kill((pid_t)pid, 0) == 0 || errno != ESRCH ||
            fstatat(dirfd(d), n, &st, AT_SYMLINK_NOFOLLOW) != 0 || st.st_uid != geteuid())
            continue;
        remove_at(dirfd(d), n, 0);
    }
    closedir(d);
}

rto_status rto__tmp_create(const char *target, bool is_dir, char **tmp_out, int *fd_out, rto_msg *msg)
{
    *tmp_out = NULL;
    if (fd_out)
        *fd_out = -1;
    remove_stale(target);
    size_t len = strlen(target);
    char *tmp = malloc(len + 40);
    if (!tmp)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    int err = EEXIST;
    for (int attempt = 0; attempt < 100 && err == EEXIST; attempt++) {
        char suffix[7];
        random_suffix(suffix);
        /* The PID lets a later run tell an abandoned temporary from a live one (remove_stale). */
        snprintf(tmp, len + 40, "%s.tmp.%ld-%s", target, (long)getpid(), suffix);
        sigset_t old;
        rto__signals_hold(&old);
        int fd = -1, ok;
        if (is_dir)
            ok = mkdir(tmp, 0777) == 0;
        else
            ok = (fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666)) >= 0;
        err = ok ? 0 : errno;
        if (ok)
            registry_add(tmp);
        rto__signals_release(&old);
        if (ok) {
            *tmp_out = tmp;
            if (fd_out)
                *fd_out = fd;
            return RTO_OK;
        }
    }
    free(tmp);
    return rto__fail(msg, RTO_ERR_IO, "cannot create a temporary %s beside %s: %s", is_dir ? "directory" : "file",
                    target, strerror(err));
}

void rto__tmp_forget(const char *tmp)
{
    if (tmp)
        registry_remove(tmp);
}

/* ---------------------------------------------------------------------------------------------------------------- */

/* Refuses a path whose directory does not exist, with a message that says so rather than ENOENT on a temporary. */
static rto_status check_parent(const char *path, const char *what, rto_msg *msg)
{
    const char *slash = strrchr(path, '/');
    if (!slash)
        return RTO_OK;
    size_t n = slash == path ? 1 : (size_t)(slash - path);
    char *parent = strndup(path, n);
    if (!parent)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    struct stat st;
    rto_status s = RTO_OK;
    if (stat(parent, &st) != 0)
        s = rto__fail(msg, RTO_ERR_IO, "cannot write %s %s: directory %s: %s", what, path, parent, strerror(errno));
    else if (!S_ISDIR(st.st_mode))
        s = rto__fail(msg, RTO_ERR_IO, "cannot write %s %s: %s is not a directory", what, path, parent);
    free(parent);
    return s;
}

rto_status rto__output_target(const char *path, bool is_dir, bool allow_special, char **where, bool *in_place,
                             rto_msg *msg)
{
    *where = NULL;
    *in_place = false;
    const char *what = is_dir ? "bundle" : "file";
    struct stat st;
    if (lstat(path, &st) != 0) {
        if (errno != ENOENT)
            return rto__fail(msg, RTO_ERR_IO, "cannot write %s %s: %s", what, path, strerror(errno));
        rto_status s = check_parent(path, what, msg);
        if (s)
            return s;
        *where = strdup(path);
        return *where ? RTO_OK : rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    }
    /* A link is followed to what it names (the link stays a link), and "." / ".." are named by their real path, so
     * the temporary sibling and the rename happen where the output really is. */
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    char *real = NULL;
    if (S_ISLNK(st.st_mode) || !strcmp(base, ".") || !strcmp(base, "..") || !*base) {
        real = realpath(path, NULL);
        if (!real && errno == ENOMEM)
            return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
        if (!real)
            return rto__fail(msg, RTO_ERR_IO, "refusing to write %s %s: it is a symbolic link to a missing path (%s)",
                            what, path, strerror(errno));
        if (stat(real, &st) != 0) {
            rto_status s = rto__fail(msg, RTO_ERR_IO, "cannot write %s %s: %s", what, real, strerror(errno));
            free(real);
            return s;
        }
    }
    const char *arrow = real ? " -> " : "", *shown = real ? real : "";
    rto_status s = RTO_OK;
    if (is_dir && !S_ISDIR(st.st_mode))
        s = rto__fail(msg, RTO_ERR_IO, "refusing to replace %s%s%s: it exists and is not a directory", path, arrow,
                     shown);
    else if (!is_dir && S_ISDIR(st.st_mode))
        s = rto__fail(msg, RTO_ERR_IO, "refusing to replace %s%s%s: it is a directory", path, arrow, shown);
    else if (!is_dir && !S_ISREG(st.st_mode) && !(allow_special && (S_ISCHR(st.st_mode) || S_ISFIFO(st.st_mode))))
        s = rto__fail(msg, RTO_ERR_IO, "refusing to replace %s%s%s: it is not a regular file", path, arrow, shown);
    else if (!is_dir && !S_ISREG(st.st_mode))
        *in_place = true; /* /dev/null, a pipe: written through the name as given, never unlinked */
    if (!s) {
        if (*in_place || !real) {
            free(real);
            real = strdup(path);
        }
        *where = real;
        real = NULL;
        if (!*where)
            s = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    }
    free(real);
    return s;
}

rto_status rto__atomic_open(rto_atomic_file *f, const char *path, bool allow_special, rto_msg *msg)
{
    memset(f, 0, sizeof *f);
    rto_status s = rto__output_target(path, false, allow_special, &f->path, &f->in_place, msg);
    if (s)
        return s;
    int fd = -1;
    if (f->in_place) {
        fd = open(f->path, O_WRONLY | O_CLOEXEC);
        if (fd < 0)
            s = rto__fail(msg, RTO_ERR_IO, "cannot open %s: %s", path, strerror(errno));
    } else {
        s = rto__tmp_create(f->path, false, &f->tmp, &fd, msg);
    }
    if (!s) {
        f->fp = fdopen(fd, "wb");
        if (!f->fp) {
            s = rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "cannot open a stream on %s: %s", path, strerror(errno));
            close(fd);
        }
    }
    if (s)
        rto__atomic_discard(f);
    return s;
}

rto_status rto__atomic_close(rto_atomic_file *f, rto_msg *msg)
{
    rto_status s = RTO_OK;
    errno = 0;
    if (f->fp) {
        bool bad = fflush(f->fp) != 0 || ferror(f->fp);
        int e = errno;
        if (fclose(f->fp) != 0 && !bad) {
            bad = true;
            e = errno;
        }
        f->fp = NULL;
        if (bad)
            s = rto__fail(msg, RTO_ERR_IO, "writing %s: %s", f->path, strerror(e ? e : EIO));
    }
    if (!s && f->tmp) {
        sigset_t old;
        rto__signals_hold(&old);
        if (rename(f->tmp, f->path) != 0) {
            s = rto__fail(msg, RTO_ERR_IO, "cannot rename %s to %s: %s", f->tmp, f->path, strerror(errno));
        } else {
            rto__tmp_forget(f->tmp);
            free(f->tmp);
            f->tmp = NULL;
        }
        rto__signals_release(&old);
    }
    rto__atomic_discard(f);
    return s;
}

void rto__atomic_discard(rto_atomic_file *f)
{
    if (f->fp)
        fclose(f->fp);
    if (f->tmp) {
        sigset_t old;
        rto__signals_hold(&old);
        unlink(f->tmp);
        rto__tmp_forget(f->tmp);
        rto__signals_release(&old);
    }
    free(f->tmp);
    free(f->path);
    memset(f, 0, sizeof *f);
}

rto_status rto_file_write(const char *path, const void *data, size_t len, rto_msg *msg)
{
    if (!path || (!data && len))
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL path or data");
    rto_atomic_file f;
    rto_status s = rto__atomic_open(&f, path, false, msg);
    if (s)
        return s;
    errno = 0;
    bool ok = fwrite(data, 1, len, f.fp) == len;
    if (!ok) {
        int e = errno;
        rto__atomic_discard(&f);
        return rto__fail(msg, RTO_ERR_IO, "writing %s: %s", path, strerror(e ? e : EIO));
    }
    return rto__atomic_close(&f, msg);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Where a command's outputs may go: never onto one of its inputs, never into a bundle (whose files are exactly those
 * its manifest lists, so that a later writer may replace it and a reader may trust it). */

/* A directory holding a manifest.json that names the bundle format. Its first 4 KiB are enough: the writer puts
 * "format" first. Opened without blocking, as a regular file only (a FIFO named manifest.json must not hang us). */
static bool is_bundle_dir(const char *dir)
{
    char *m = rto__path_join(dir, "manifest.json");
    if (!m)
        return false;
    int fd = open(m, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    free(m);
    if (fd < 0)
        return false;
    struct stat st;
    char head[4097];
    ssize_t got = fstat(fd, &st) == 0 && S_ISREG(st.st_mode) ? read(fd, head, sizeof head - 1) : -1;
    close(fd);
    if (got <= 0)
        return false;
    head[got] = '\0';
    return strstr(head, "\"rtoracle-bundle\"") != NULL;
}

rto_status rto_output_check(const char *path, int is_dir, const char *const *inputs, size_t n, rto_msg *msg)
{
    if (!path)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "no output path given");
    struct stat so;
    const bool exists = stat(path, &so) == 0;
    for (size_t i = 0; exists && i < n; i++) {
        struct stat si;
        if (inputs[i] && stat(inputs[i], &si) == 0 && si.st_dev == so.st_dev && si.st_ino == so.st_ino)
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "refusing to write %s: it is the input %s", path,
                            inputs[i]);
    }
    /* The directory the output lands in (the output itself for a directory that exists), then each one above it. */
    char *start = NULL;
    if (is_dir && exists && S_ISDIR(so.st_mode)) {
        start = strdup(path);
    } else {
        const char *slash = strrchr(path, '/');
        start = slash ? strndup(path, slash == path ? 1 : (size_t)(slash - path)) : strdup(".");
    }
    char *dir = start ? realpath(start, NULL) : NULL;
    free(start);
    if (!dir)
        return RTO_OK; /* a missing directory: the writer says so in its own words */
    rto_status s = RTO_OK;
    for (;;) {
        if (is_bundle_dir(dir)) {
            s = rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                         "refusing to write %s: it is inside the bundle %s, which holds only the files its manifest "
                         "lists (write it elsewhere)", path, dir);
            break;
        }
        char *slash = strrchr(dir, '/');
        if (!slash || slash == dir)
            break;
        *slash = '\0';
    }
    free(dir);
    return s;
}
