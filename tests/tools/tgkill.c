/* Sends a signal to one thread of a process (tgkill), for tests/cli_signals.sh: the shell's kill only names
 * processes, whose signals the kernel gives to whichever thread does not block them.
 *   tgkill PID TID SIGNAL-NUMBER */
#define _GNU_SOURCE
#include <stdio.h>
#include <stdlib.h>
#include <sys/syscall.h>
#include <unistd.h>

int main(int argc, char **argv)
{
    if (argc != 4) {
        fprintf(stderr, "usage: tgkill PID TID SIGNAL-NUMBER\n");
        return 2;
    }
    if (syscall(SYS_tgkill, atoi(argv[1]), atoi(argv[2]), atoi(argv[3])) != 0) {
        perror("tgkill");
        return 1;
    }
    return 0;
}
