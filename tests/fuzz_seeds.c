/* fuzz_seeds.c - writes the seed corpus of tests/fuzz_wire.c (valid
   datagrams made by the library's own encoder) and tests/fuzz_clock.c
   (clock-*: programs of round trips and forged datagrams).

       fuzz_seeds DIR

   Hosts 2 and 3 of tests/fuzz_world.h run their copy of the world and send
   to host 1 through a transport that keeps every datagram; each seed file
   holds one of them, or several back to back (the harness cuts an input
   before every "GSIM"):
     net-*       what gs_net_update sends: the cloths in f64 (3 chunks) and
                 f32 (2 chunks), the small objects packed in one datagram
     snapshot-*  every datagram of one update: whole multi-chunk snapshots
     run-*       two updates in a row from one host; one of each host
     wire-*      made with gs_wire_begin/add/end by hand: one chunk of each
                 object alone, f32 and f64, zero values, a late chunk first,
                 more snapshots than a queue holds, values and times at the
                 limits of f64 and f32
   Only the public API is used. Exits non-zero if a file cannot be written
   or a world cannot be built. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_world.h"

#define MAX_KEPT 256

typedef struct kept {
    size_t size;
    unsigned char data[GS_WIRE_MAX_DATAGRAM];
} kept;

typedef struct sink {
    kept d[MAX_KEPT];
    int count;
} sink;

static const char *out_dir;
static int written;

static gs_result keep(void *user, uint32_t host, const void *data, size_t size) {
    sink *s = (sink *)user;
    if (host != FUZZ_HOST || s->count == MAX_KEPT || size > GS_WIRE_MAX_DATAGRAM)
        return GS_OK;
    memcpy(s->d[s->count].data, data, size);
    s->d[s->count].size = size;
    s->count++;
    return GS_OK;
}

/* Writes datagrams [from, to) of s back to back as one seed file. */
static void write_seed(const char *name, const sink *s, int from, int to) {
    char path[1024];
    FILE *fp;
    int i;
    snprintf(path, sizeof path, "%s/%s", out_dir, name);
    fp = fopen(path, "wb");
    if (!fp) { perror(path); exit(1); }
    for (i = from; i < to; ++i)
        if (fwrite(s->d[i].data, 1, s->d[i].size, fp) != s->d[i].size) { perror(path); exit(1); }
    if (fclose(fp) != 0) { perror(path); exit(1); }
    written++;
}

static void must(gs_result r, const char *what) {
    if (r != GS_OK) {
        fprintf(stderr, "fuzz_seeds: %s: %s\n", what, gs_result_str(r));
        exit(1);
    }
}

/* One sending host: runs `updates` frames of 1/60 s and records each
   update's datagrams; seeds of single datagrams, whole updates, the run. */
static void from_host(uint32_t host, int updates, sink *all) {
    static sink s;
    fuzz_world f;
    char name[64];
    int u, i, first;
    memset(&s, 0, sizeof s);
    must(fuzz_world_create(&f, host, 0.0, keep, &s), "world");
    for (u = 0; u < updates; ++u) {
        must(gs_world_advance(f.w, 1.0 / 60.0, NULL), "advance");
        first = s.count;
        must(gs_net_update(f.net, 10.0 + 0.02 * u), "update");
        for (i = first; i < s.count; ++i) {
            snprintf(name, sizeof name, "net-h%u-u%d-d%d", (unsigned)host, u, i - first);
            write_seed(name, &s, i, i + 1);
        }
        snprintf(name, sizeof name, "snapshot-h%u-u%d", (unsigned)host, u);
        if (s.count > first) write_seed(name, &s, first, s.count);
    }
    snprintf(name, sizeof name, "run-h%u", (unsigned)host);
    write_seed(name, &s, 0, s.count < 10 ? s.count : 10);
    for (i = 0; i < s.count && i < 5 && all->count < MAX_KEPT; ++i)
        all->d[all->count++] = s.d[i];
    fuzz_world_destroy(&f);
}

/* One hand-made datagram from host 2 with the given chunks. */
static void wire_seed(const char *name, uint32_t seq, const gs_wire_chunk *c, int n,
                      const double *values) {
    static sink s;
    gs_wire_header h;
    size_t size;
    int i;
    memset(&h, 0, sizeof h);
    h.session = FUZZ_SESSION;
    h.sender = FUZZ_PEER_A;
    h.sequence = seq;
    h.send_time = 10.0;
    h.echo_time = 9.99;
    h.echo_hold = 0.001;
    s.count = 1;
    must(gs_wire_begin(s.d[0].data, GS_WIRE_MAX_DATAGRAM, &h, &size), name);
    for (i = 0; i < n; ++i)
        must(gs_wire_add(s.d[0].data, GS_WIRE_MAX_DATAGRAM, &size, &c[i], values), name);
    s.d[0].size = gs_wire_end(s.d[0].data, size);
    write_seed(name, &s, 0, 1);
}

static gs_wire_chunk chunk(uint32_t object, double time, uint16_t index, uint16_t count,
                           uint32_t first, uint16_t elements, gs_encoding enc) {
    gs_wire_chunk c;
    memset(&c, 0, sizeof c);
    c.object_id = object;
    c.sequence = 5;
    c.time = time;
    c.index = index;
    c.count = count;
    c.first = first;
    c.elements = elements;
    c.encoding = enc;
    return c;
}

/* Chunks that the harness's world takes (the ranges of its ghosts: a
   cloth of 294 values takes 139 + 139 + 16 in f64, the chain of 288 takes 279 + 9 in f32) and a few that it refuses
   for a reason past decoding. */
static void extremes(double *v);

static void hand_made(void) {
    static double v[300];
    gs_wire_chunk c[4], big[6];
    int i;
    for (i = 0; i < 300; ++i) v[i] = 0.01 * (i % 17) - 0.05;
    v[3] = 0.0; v[4] = 0.0; v[5] = 0.0; v[6] = 1.0; /* a unit quaternion */
    c[0] = chunk(12, 0.05, 0, 1, 0, 13, GS_ENCODING_F64);
    wire_seed("wire-rigid", 1, c, 1, v);
    c[0] = chunk(13, 0.05, 0, 1, 0, 13, GS_ENCODING_F32);
    wire_seed("wire-probe-f32", 2, c, 1, v);
    c[0] = chunk(14, 0.05, 0, 1, 0, 6, GS_ENCODING_F64);
    wire_seed("wire-point", 3, c, 1, v);
    c[0] = chunk(15, 0.05, 0, 1, 0, 0, GS_ENCODING_F64);
    wire_seed("wire-empty", 4, c, 1, v);
    c[0] = chunk(10, 0.05, 2, 3, 278, 16, GS_ENCODING_F64); /* last chunk only */
    wire_seed("wire-cloth-last", 5, c, 1, v);
    c[0] = chunk(11, 0.05, 1, 2, 279, 9, GS_ENCODING_F32);
    wire_seed("wire-cloth-f32-last", 6, c, 1, v);
    c[0] = chunk(12, 0.05, 0, 1, 0, 13, GS_ENCODING_F64);
    c[1] = chunk(14, 0.05, 0, 1, 0, 6, GS_ENCODING_F64);
    c[2] = chunk(15, 0.05, 0, 1, 0, 0, GS_ENCODING_F64);
    c[3] = chunk(13, 0.05, 0, 1, 0, 13, GS_ENCODING_F32);
    wire_seed("wire-packed", 7, c, 4, v);
    c[0] = chunk(99, 0.05, 0, 1, 0, 2, GS_ENCODING_F64); /* unknown object */
    wire_seed("wire-unknown-object", 8, c, 1, v);
    c[0] = chunk(12, 0.05, 0, 1, 0, 12, GS_ENCODING_F64); /* short range */
    wire_seed("wire-bad-range", 9, c, 1, v);
    c[0] = chunk(14, 1e9, 0, 1, 0, 6, GS_ENCODING_F64); /* far ahead */
    wire_seed("wire-far-time", 10, c, 1, v);
    c[0] = chunk(14, 0.0, 0, 1, 0, 6, GS_ENCODING_F64);
    wire_seed("wire-zero-time", 0xffffffffu, c, 1, v);
    for (i = 0; i < 6; ++i) { /* six snapshots of a queue of four */
        big[i] = chunk(15, 0.05 + 0.001 * i, 0, 1, 0, 0, GS_ENCODING_F64);
        big[i].sequence = 100u + (uint32_t)i;
    }
    wire_seed("wire-queue-overflow", 11, big, 6, v);
    extremes(v);
}

/* Values and times at the edges: the largest f64 and f32, subnormals,
   -0, the latest time the wire carries (GS_WIRE_MAX_TIME; the fuzzer
   mutates it past the edge, which decode must refuse). */
static void extremes(double *v) {
    gs_wire_chunk c[2];
    int i;
    for (i = 0; i < 300; ++i) v[i] = i % 3 == 0 ? 1.7976931348623157e308 : i % 3 == 1 ? -1e300 : 4.9e-324;
    v[3] = 0.0; v[4] = -0.0; v[5] = 0.0; v[6] = 1.0;
    c[0] = chunk(12, 0.05, 0, 1, 0, 13, GS_ENCODING_F64);
    c[1] = chunk(14, 0.05, 0, 1, 0, 6, GS_ENCODING_F64);
    wire_seed("wire-huge-f64", 12, c, 2, v);
    for (i = 0; i < 300; ++i) v[i] = i % 2 ? 3.4028234663852886e38 : -1.4e-45;
    c[0] = chunk(13, 0.05, 0, 1, 0, 13, GS_ENCODING_F32);
    c[1] = chunk(11, 0.05, 1, 2, 279, 9, GS_ENCODING_F32);
    wire_seed("wire-huge-f32", 13, c, 2, v);
    for (i = 0; i < 300; ++i) v[i] = 0.01 * i;
    c[0] = chunk(14, GS_WIRE_MAX_TIME, 0, 1, 0, 6, GS_ENCODING_F64);
    c[1] = chunk(12, GS_WIRE_MAX_TIME, 0, 1, 0, 13, GS_ENCODING_F64);
    wire_seed("wire-time-max", 14, c, 2, v);
}

/* Programs of tests/fuzz_clock.c (4-byte operations; its top comment):
   frames of honest round trips, then one forged datagram of each kind
   (send time off by 100 s, 0, -1e300; a snapshot a year on), a wall-time
   jump and a peer's clock stepped, frames between. */
static void clock_seeds(void) {
    static const unsigned char frame[4] = {0, 0, 0, 0};
    static const unsigned char odd[6][4] = {
        {2, 0, 6, 0x21}, {2, 0, 10, 0x20}, {3, 0, 14, 0xe0}, {2, 12, 2, 0x21}, {5, 7, 3, 0},
        {4, 4, 0, 0}};
    char name[64];
    FILE *fp;
    int i, k;
    for (i = 0; i < 6; ++i) {
        snprintf(name, sizeof name, "%s/clock-%d", out_dir, i);
        fp = fopen(name, "wb");
        if (!fp) { perror(name); exit(1); }
        for (k = 0; k < 20; ++k) fwrite(frame, 1, 4, fp);
        fwrite(odd[i], 1, 4, fp);
        for (k = 0; k < 10; ++k) fwrite(frame, 1, 4, fp);
        if (fclose(fp) != 0) { perror(name); exit(1); }
        written++;
    }
}

int main(int argc, char **argv) {
    static sink all;
    if (argc != 2) {
        fprintf(stderr, "usage: fuzz_seeds DIR\n");
        return 2;
    }
    out_dir = argv[1];
    from_host(FUZZ_PEER_A, 3, &all);
    from_host(FUZZ_PEER_B, 2, &all);
    write_seed("run-both", &all, 0, all.count);
    hand_made();
    clock_seeds();
    printf("fuzz_seeds: %d seed files in %s\n", written, out_dir);
    return 0;
}
