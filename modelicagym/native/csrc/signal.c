/* See signal.h. Linux futexes on shared (not process-private) memory. */
#define _GNU_SOURCE
#include "signal.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <linux/futex.h>
#include <stdlib.h>
#include <string.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#if defined(__x86_64__) || defined(__i386__)
#define CPU_RELAX() __builtin_ia32_pause()
#elif defined(__aarch64__)
#define CPU_RELAX() __asm__ __volatile__("yield")
#else
#define CPU_RELAX() ((void)0)
#endif

/* Polls between two clock readings while spinning (a reading costs ~20 ns, a pause ~20-50). */
#define POLLS_PER_READING 16
/* A gap this long between two clock readings of a poll: the poller was descheduled. A timer
 * interrupt takes a few microseconds; losing the core to another thread takes a scheduler slice
 * (hundreds of microseconds or more). */
#define DESCHEDULED_NS 50000
/* The machine's load is re-read at most this often (one pread of /proc, ~2 us). */
#define CHECK_EVERY_NS 1000000
/* Some runnable thread waited for a core this share of the time since the last reading: crowded. */
#define CROWDED_STALL_SHARE 0.05
/* How long a process sleeps at once after it saw crowding: doubled while crowding persists. */
#define HOLD_MIN_NS 2000000
#define HOLD_MAX_NS 256000000

int64_t mg_now_ns(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

static long futex(uint32_t *word, int op, uint32_t value, const struct timespec *timeout, uint32_t bits) {
    return syscall(SYS_futex, word, op, value, timeout, NULL, bits);
}

void mg_signal_set(mg_signal *signal) {
    __atomic_store_n(&signal->posted_ns, mg_now_ns(), __ATOMIC_RELAXED);
    __atomic_store_n(&signal->posted, 1, __ATOMIC_SEQ_CST);
}

int mg_signal_sleeps(const mg_signal *signal) { return __atomic_load_n(&signal->sleepers, __ATOMIC_SEQ_CST) != 0; }

void mg_signal_post(mg_signal *signal) {
    mg_signal_set(signal);
    if (mg_signal_sleeps(signal))
        futex(&signal->posted, FUTEX_WAKE, INT_MAX, NULL, 0);
}

/* The bump comes after the signals' sets: a waiter that read the bell before it finds its word
 * changed when it goes to sleep (the kernel compares it), one that read it after sees its post. */
void mg_bell_ring(uint32_t *bell, uint32_t bits, int wake) {
    __atomic_add_fetch(bell, 1, __ATOMIC_SEQ_CST);
    if (wake)
        futex(bell, FUTEX_WAKE_BITSET, INT_MAX, NULL, bits);
}

void mg_signal_post_bell(mg_signal *signal, uint32_t *bell, uint32_t bits) {
    mg_signal_set(signal);
    mg_bell_ring(bell, bits, mg_signal_sleeps(signal));
}

int mg_signal_try(mg_signal *signal) {
    return __atomic_load_n(&signal->posted, __ATOMIC_ACQUIRE) &&
           __atomic_exchange_n(&signal->posted, 0, __ATOMIC_ACQ_REL);
}

/* ---- is the machine crowded? (process-wide: the machine is the same for every waiter) ---- */

static struct {
    int fd;               /* /proc/pressure/cpu or /proc/loadavg; -1: neither readable */
    int psi;              /* fd is PSI */
    long host_cpus;       /* the CPUs /proc/loadavg counts runnable threads on: all the host's online ones */
    int64_t checked_ns;   /* last reading */
    int64_t stall_us;     /* PSI "some" total at the last reading */
    int64_t until_ns;     /* sleep at once until then */
    int64_t hold_ns;      /* the last hold */
} machine = {.fd = -2};

static int read_proc(char *buffer, size_t size) {
    ssize_t n = pread(machine.fd, buffer, size - 1, 0);
    if (n <= 0)
        return 0;
    buffer[n] = '\0';
    return 1;
}

static void open_machine(void) {
    machine.fd = open("/proc/pressure/cpu", O_RDONLY | O_CLOEXEC);
    machine.psi = machine.fd >= 0;
    char buffer[256];
    if (machine.psi && !read_proc(buffer, sizeof buffer)) { /* PSI present but switched off */
        close(machine.fd);
        machine.psi = 0;
    }
    if (!machine.psi)
        machine.fd = open("/proc/loadavg", O_RDONLY | O_CLOEXEC);
    machine.host_cpus = sysconf(_SC_NPROCESSORS_ONLN);
    if (machine.host_cpus < 1)
        machine.host_cpus = 1;
}

/* Crowded since the last reading, by the kernel's own account. */
static int read_crowded(int64_t now, int64_t elapsed_ns) {
    char buffer[256];
    if (!read_proc(buffer, sizeof buffer))
        return 0;
    if (machine.psi) { /* "some avg10=0.00 avg60=0.00 avg300=0.00 total=123" */
        char *total = strstr(buffer, "total=");
        if (!total)
            return 0;
        int64_t stall_us = strtoll(total + 6, NULL, 10), before = machine.stall_us;
        machine.stall_us = stall_us;
        return before > 0 && elapsed_ns > 0 && (double)(stall_us - before) * 1e3 > CROWDED_STALL_SHARE * (double)elapsed_ns;
    }
    /* "0.03 0.18 0.10 2/85 2439": runnable threads (this one included) / all, on the whole host (a
     * container's too), so they are compared with the host's CPUs, not with this process's affinity */
    char *slash = strchr(buffer, '/');
    if (!slash)
        return 0;
    char *runnable = slash;
    while (runnable > buffer && runnable[-1] != ' ')
        runnable--;
    (void)now;
    return strtol(runnable, NULL, 10) > machine.host_cpus;
}

static void hold(int64_t now) {
    int64_t hold_ns = machine.hold_ns;
    /* crowding again right after the last hold ended: it persists, hold longer */
    hold_ns = (hold_ns && now - machine.until_ns < hold_ns) ? hold_ns * 2 : HOLD_MIN_NS;
    machine.hold_ns = hold_ns > HOLD_MAX_NS ? HOLD_MAX_NS : hold_ns;
    machine.until_ns = now + machine.hold_ns;
}

/* Read the machine if a reading is due: 1 when it found it crowded (a hold starts, unless one runs). */
static int read_machine(int64_t now) {
    int64_t elapsed = now - machine.checked_ns;
    if (elapsed < CHECK_EVERY_NS)
        return 0;
    if (machine.fd == -2)
        open_machine();
    machine.checked_ns = now;
    if (machine.fd < 0 || !read_crowded(now, elapsed))
        return 0;
    if (now >= machine.until_ns)
        hold(now);
    return 1;
}

static int crowded(int64_t now) { return now < machine.until_ns || read_machine(now); }

int mg_machine_crowded(void) { return crowded(mg_now_ns()); }

int64_t mg_machine_stall_us(void) {
    read_machine(mg_now_ns());
    return machine.fd >= 0 && machine.psi && machine.stall_us > 0 ? machine.stall_us : -1;
}

/* ---- the wait ---- */

/* Poll until posted (1) or the spin time is over or this process lost its core (0). */
static int poll_for(mg_signal *signal, int64_t start, int64_t spin_ns) {
    int64_t end = start + spin_ns, last = start;
    for (;;) {
        for (int k = 0; k < POLLS_PER_READING; k++) {
            CPU_RELAX();
            if (mg_signal_try(signal))
                return 1;
        }
        int64_t now = mg_now_ns();
        if (now - last > DESCHEDULED_NS) {
            hold(now);
            return 0;
        }
        if (now >= end)
            return 0;
        last = now;
    }
}

/* Where a waiter sleeps: its signal's own word, or a bell (signal.h) on its bits. */
typedef struct {
    uint32_t *word;
    uint32_t bits;
} sleep_place;

static int sleep_until_posted(mg_signal *signal, sleep_place place, int64_t deadline) {
    struct timespec at = {.tv_sec = deadline / 1000000000, .tv_nsec = deadline % 1000000000};
    __atomic_add_fetch(&signal->sleepers, 1, __ATOMIC_SEQ_CST);
    int got = 0;
    for (;;) {
        /* a bell is read before the post is looked at: a ring in between changes the word, so the
         * futex wait below returns at once instead of sleeping through the post */
        uint32_t expected = place.word == &signal->posted ? 0 : __atomic_load_n(place.word, __ATOMIC_SEQ_CST);
        if (mg_signal_try(signal)) {
            got = 1;
            break;
        }
        if (deadline >= 0 && mg_now_ns() >= deadline)
            break;
        /* FUTEX_WAIT_BITSET's timeout is absolute, on CLOCK_MONOTONIC (mg_now_ns's clock) */
        futex(place.word, FUTEX_WAIT_BITSET, expected, deadline >= 0 ? &at : NULL, place.bits);
    }
    __atomic_sub_fetch(&signal->sleepers, 1, __ATOMIC_SEQ_CST);
    return got;
}

static int wait_for(mg_signal *signal, sleep_place place, int64_t spin_ns, int64_t timeout_ns, mg_waiter *waiter) {
    mg_waiter scratch = {0};
    if (!waiter)
        waiter = &scratch;
    if (mg_signal_try(signal)) {
        waiter->ready++;
        waiter->long_waits = 0;
        return 1;
    }
    int64_t start = mg_now_ns();
    int spin = spin_ns > 0 && waiter->long_waits == 0 && !crowded(start);
    if (spin && poll_for(signal, start, spin_ns)) {
        waiter->spun++;
        return 1;
    }
    int got = sleep_until_posted(signal, place, timeout_ns < 0 ? -1 : start + timeout_ns);
    if (spin)
        waiter->slept++;
    else
        waiter->blocked++;
    int64_t posted_after = __atomic_load_n(&signal->posted_ns, __ATOMIC_RELAXED) - start;
    waiter->long_waits = !got || posted_after > spin_ns ? waiter->long_waits + 1 : 0;
    return got;
}

int mg_signal_wait(mg_signal *signal, int64_t spin_ns, int64_t timeout_ns, mg_waiter *waiter) {
    return wait_for(signal, (sleep_place){&signal->posted, FUTEX_BITSET_MATCH_ANY}, spin_ns, timeout_ns, waiter);
}

int mg_signal_wait_bell(mg_signal *signal, uint32_t *bell, uint32_t bits, int64_t spin_ns, int64_t timeout_ns,
                        mg_waiter *waiter) {
    return wait_for(signal, (sleep_place){bell, bits}, spin_ns, timeout_ns, waiter);
}
