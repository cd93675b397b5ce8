/* alloc_helpers.h - the tests' counting allocator: what a world allocates
   and frees through its hook (blocks, calls, bytes live and the peak), and
   refusals on demand, to see that a failed call leaks nothing and that a
   step allocates nothing. Include after cmocka.h and ghostsim.h. */
#ifndef GS_TEST_ALLOC_HELPERS_H
#define GS_TEST_ALLOC_HELPERS_H

#include <stdlib.h>
#include <string.h>

#include "helpers.h"

/* Each block is prefixed with its size, so that a free can be counted in
   bytes; the union keeps what follows aligned for any type. */
typedef union block_head {
    size_t size;
    long double align_ld;
    void *align_p;
    long long align_ll;
} block_head;

/* All zero is a counter that refuses nothing; counted_world_desc resets
   it so, and the test then sets the failure modes it wants. */
typedef struct counter {
    long allocs, frees;    /* blocks given and taken back */
    unsigned long calls;   /* requests, refused ones included */
    long refused;          /* requests answered NULL */
    size_t live, peak;     /* bytes given and not yet freed; their maximum */
    long fail_once;        /* > 0: the fail_once-th request from now fails,
                              the ones after it do not */
    long fail_from;        /* > 0: every request fails once fail_from - 1
                              blocks have been given (1: all of them);
                              0 never */
    int lie;               /* 1: a request over a gigabyte gets 4 KiB (a
                              test that never writes past that sees the
                              huge size taken); 0: it is refused, as an
                              allocator on a small machine would */
} counter;

static GS_TEST_UNUSED void *count_alloc(size_t size, void *user) {
    counter *c = (counter *)user;
    block_head *h;
    c->calls++;
    if ((c->fail_once > 0 && --c->fail_once == 0) ||
        (c->fail_from > 0 && c->allocs >= c->fail_from - 1) ||
        (size > ((size_t)1 << 30) && !c->lie)) {
        c->refused++;
        return NULL;
    }
    if (size > ((size_t)1 << 30)) size = 4096;
    h = (block_head *)malloc(sizeof *h + size);
    if (!h) {
        c->refused++;
        return NULL;
    }
    h->size = size;
    c->allocs++;
    c->live += size;
    if (c->live > c->peak) c->peak = c->live;
    return h + 1;
}

static GS_TEST_UNUSED void count_free(void *ptr, void *user) {
    counter *c = (counter *)user;
    block_head *h;
    if (!ptr) return;
    h = (block_head *)ptr - 1;
    c->frees++;
    c->live -= h->size;
    free(h);
}

/* Blocks given and not yet freed. */
static GS_TEST_UNUSED long live_blocks(const counter *c) { return c->allocs - c->frees; }

/* The default world desc on c, which starts from zero and never fails. */
static GS_TEST_UNUSED gs_world_desc counted_world_desc(counter *c) {
    gs_world_desc wd = gs_world_desc_default();
    memset(c, 0, sizeof *c);
    wd.allocator.alloc = count_alloc;
    wd.allocator.free = count_free;
    wd.allocator.user = c;
    return wd;
}

/* A world of host `host` on c (counted_world_desc). */
static GS_TEST_UNUSED gs_world *counted_world(counter *c, uint32_t host) {
    gs_world_desc wd = counted_world_desc(c);
    gs_world *w = NULL;
    wd.host_id = host;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    return w;
}

#endif
