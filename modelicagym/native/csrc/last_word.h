/* The calling process's last word when an env it steps itself ends it.
 *
 * A pool whose calling process steps envs itself (caller_steps=True, num_workers=0) registers the
 * address of the caller's "current env" slot and a label per env (its FMU). While the calling
 * process runs an env's code, mg_caller_slot points at that slot: mg_step_batch sets it for a
 * caller's slice, Python around its own calls into the envs (vector/dispatch/caller_watch.py). A fatal
 * signal (SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT) or exit() meanwhile prints one line to stderr
 * naming the env and its label before the process ends: the signal then goes on to the handler
 * that was there before (Python's faulthandler, or the default: the process dies of it); exit()
 * ends the process with its status, or with MG_EXIT_STATUS where that was 0, so that a program
 * whose FMU quit never looks successful. Outside an env's code the handlers pass everything on
 * unchanged. The cost on the hot path: two stores per batch of the caller's slice.
 */
#ifndef MG_LAST_WORD_H
#define MG_LAST_WORD_H

#include <stdint.h>

/* the status of a process whose env called exit(0) while the calling process stepped it */
#define MG_EXIT_STATUS 70

/* the caller's current-env slot while it runs an env's code, else NULL */
extern int64_t *volatile mg_caller_slot;

/* Remember the labels of a pool's envs (labels[i]: env i's, copied) for the slot `slot`, and
 * install the handlers (once per process). Returns 0, or -1 if memory ran out. */
int32_t mg_watch_register(int64_t *slot, int64_t n_envs, const char *const *labels);

/* Forget the labels of `slot` (the pool closed). */
void mg_watch_unregister(int64_t *slot);

#endif /* MG_LAST_WORD_H */
