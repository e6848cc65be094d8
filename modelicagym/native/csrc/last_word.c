/* See last_word.h. */
#define _GNU_SOURCE
#include "last_word.h"

#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

typedef struct watch {
    int64_t *slot;
    int64_t n;
    char **labels;
    struct watch *next;
} watch;

int64_t *volatile mg_caller_slot = NULL;

static watch *volatile watches = NULL;
static pthread_mutex_t watches_lock = PTHREAD_MUTEX_INITIALIZER;
static int installed = 0;

static const int fatal_signals[] = {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT};
static const char *const fatal_names[] = {"SIGSEGV", "SIGBUS", "SIGFPE", "SIGILL", "SIGABRT"};
#define N_FATAL ((int)(sizeof fatal_signals / sizeof fatal_signals[0]))
static struct sigaction previous[N_FATAL];

/* A line built without allocation (async-signal-safe). */
typedef struct {
    char text[1024];
    size_t len;
} line;

static void put(line *l, const char *s) {
    while (*s && l->len < sizeof l->text - 1)
        l->text[l->len++] = *s++;
}

static void put_int(line *l, int64_t v) {
    char digits[24];
    int k = 0;
    uint64_t u = v < 0 ? (uint64_t)0 - (uint64_t)v : (uint64_t)v;
    do {
        digits[k++] = (char)('0' + u % 10);
        u /= 10;
    } while (u);
    if (v < 0)
        put(l, "-");
    while (k)
        l->text[l->len < sizeof l->text - 1 ? l->len++ : l->len] = digits[--k];
}

/* The first part of the line, naming the env the calling process was running; NULL slot: none. */
static int begin(line *l) {
    int64_t *slot = mg_caller_slot;
    if (!slot)
        return 0;
    mg_caller_slot = NULL; /* one line, even if ending the process faults again */
    int64_t env = *slot;
    const char *label = NULL;
    for (watch *w = watches; w; w = w->next)
        if (w->slot == slot && env >= 0 && env < w->n)
            label = w->labels[env];
    put(l, "modelicagym: env ");
    put_int(l, env);
    if (label && *label) {
        put(l, " (");
        put(l, label);
        put(l, ")");
    }
    put(l, ", which the calling process steps itself, ");
    return 1;
}

static void say(line *l) {
    put(l, " (the pool's default keeps such envs in worker processes)\n");
    ssize_t ignored = write(STDERR_FILENO, l->text, l->len);
    (void)ignored;
}

static void on_fatal_signal(int sig, siginfo_t *info, void *context) {
    int k = 0;
    while (k < N_FATAL - 1 && fatal_signals[k] != sig)
        k++;
    line l = {.len = 0};
    if (begin(&l)) {
        put(&l, "crashed with ");
        put(&l, fatal_names[k]);
        put(&l, "; the process ends");
        say(&l);
    }
    /* what would have happened without us */
    struct sigaction *old = &previous[k];
    if (old->sa_flags & SA_SIGINFO) {
        old->sa_sigaction(sig, info, context);
    } else if (old->sa_handler == SIG_DFL) {
        signal(sig, SIG_DFL);
        raise(sig); /* delivered when this handler returns (a fault also recurs then) */
    } else if (old->sa_handler != SIG_IGN) {
        old->sa_handler(sig);
    }
}

static void on_exit_call(int status, void *unused) {
    (void)unused;
    line l = {.len = 0};
    if (!begin(&l))
        return;
    int ending = status != 0 ? status : MG_EXIT_STATUS;
    put(&l, "called exit(");
    put_int(&l, status);
    put(&l, ") while it stepped; the process ends with status ");
    put_int(&l, ending);
    say(&l);
    fflush(NULL);
    _exit(ending);
}

static void install(void) {
    struct sigaction action;
    memset(&action, 0, sizeof action);
    action.sa_sigaction = on_fatal_signal;
    action.sa_flags = SA_SIGINFO | SA_ONSTACK;
    sigemptyset(&action.sa_mask);
    for (int k = 0; k < N_FATAL; k++)
        sigaction(fatal_signals[k], &action, &previous[k]);
    on_exit(on_exit_call, NULL);
    installed = 1;
}

int32_t mg_watch_register(int64_t *slot, int64_t n_envs, const char *const *labels) {
    watch *w = calloc(1, sizeof *w);
    char **copies = calloc((size_t)(n_envs > 0 ? n_envs : 1), sizeof *copies);
    if (!w || !copies) {
        free(w);
        free(copies);
        return -1;
    }
    for (int64_t i = 0; i < n_envs; i++)
        copies[i] = strdup(labels[i] ? labels[i] : "");
    w->slot = slot;
    w->n = n_envs;
    w->labels = copies;
    pthread_mutex_lock(&watches_lock);
    if (!installed)
        install();
    w->next = watches;
    watches = w;
    pthread_mutex_unlock(&watches_lock);
    return 0;
}

void mg_watch_unregister(int64_t *slot) {
    pthread_mutex_lock(&watches_lock);
    watch *volatile *link = &watches;
    while (*link && (*link)->slot != slot)
        link = &(*link)->next;
    watch *w = *link;
    if (w)
        *link = w->next;
    pthread_mutex_unlock(&watches_lock);
    if (!w)
        return;
    for (int64_t i = 0; i < w->n; i++)
        free(w->labels[i]);
    free(w->labels);
    free(w);
}
