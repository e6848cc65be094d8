/* See signal.h. Linux futexes on shared (not process-private) memory. */
#define _GNU_SOURCE
#include "signal.h"

#include <errno.h>
#include <limits.h>
#include <linux/futex.h>
#include <sched.h>
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

int64_t mg_now_ns(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

static long futex(uint32_t *word, int op, uint32_t value, const struct timespec *timeout) {
    return syscall(SYS_futex, word, op, value, timeout, NULL, 0);
}

void mg_signal_post(mg_signal *signal) {
    __atomic_store_n(&signal->posted, 1, __ATOMIC_SEQ_CST);
    if (__atomic_load_n(&signal->sleepers, __ATOMIC_SEQ_CST))
        futex(&signal->posted, FUTEX_WAKE, INT_MAX, NULL);
}

int mg_signal_try(mg_signal *signal) {
    return __atomic_load_n(&signal->posted, __ATOMIC_ACQUIRE) &&
           __atomic_exchange_n(&signal->posted, 0, __ATOMIC_ACQ_REL);
}

int mg_signal_wait(mg_signal *signal, int64_t spin_ns, int64_t timeout_ns, int yield) {
    if (mg_signal_try(signal))
        return 1;
    int64_t start = mg_now_ns();
    if (spin_ns > 0) {
        int64_t spin_end = start + spin_ns;
        for (unsigned k = 1;; k++) {
            if (yield)
                sched_yield();
            else
                CPU_RELAX();
            if (mg_signal_try(signal))
                return 1;
            if ((k & 63) == 0 && mg_now_ns() >= spin_end)
                break;
        }
    }
    int64_t deadline = timeout_ns < 0 ? -1 : start + timeout_ns;
    __atomic_add_fetch(&signal->sleepers, 1, __ATOMIC_SEQ_CST);
    int got = 0;
    for (;;) {
        if (mg_signal_try(signal)) {
            got = 1;
            break;
        }
        struct timespec ts, *timeout = NULL;
        if (deadline >= 0) {
            int64_t left = deadline - mg_now_ns();
            if (left <= 0)
                break;
            ts.tv_sec = left / 1000000000;
            ts.tv_nsec = left % 1000000000;
            timeout = &ts;
        }
        futex(&signal->posted, FUTEX_WAIT, 0, timeout);
    }
    __atomic_sub_fetch(&signal->sleepers, 1, __ATOMIC_SEQ_CST);
    return got;
}
