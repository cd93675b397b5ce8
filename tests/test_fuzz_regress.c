/* test_fuzz_regress.c - replays every input of tests/fuzz-regressions/
   through the fuzz harnesses' checks (tests/fuzz_wire.c, datagrams in
   clear; tests/fuzz_sealed.c, the same sealed to a keyed net; and
   tests/fuzz_clock.c, the bytes as a program of datagrams, round trips and
   clock jumps; all included here).

   Each file there is an input that once made the fuzzer fail: a crash, a
   sanitizer report, a hang or a broken check. Replayed here in the plain
   run, under ASan+UBSan and under valgrind, they keep the fixes fixed
   without clang or libFuzzer. A file is one or more datagrams back to back,
   exactly as the fuzzer saw it (see the harness's top comment); its name
   says what it found. One cmocka test per file, named after it.

   The directory is tests/fuzz-regressions next to this source (run from
   the repository root, as make does), or $GS_FUZZ_REGRESSIONS. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void fuzz_fail(const char *what, const char *file, int line) {
    print_error("fuzz check failed: %s\n", what);
    _fail(file, line);
}
#define FUZZ_FAIL(what) fuzz_fail(what, __FILE__, __LINE__)
#define FUZZ_NO_ENTRY
#include "fuzz_sealed.c"
#include "fuzz_clock.c"

#define MAX_FILES 512

static char dir[1024];
static char *names[MAX_FILES];
static struct CMUnitTest tests[MAX_FILES + 2];

static void replay(void **state) {
    const char *name = (const char *)*state;
    char path[2048];
    unsigned char *data;
    long size;
    FILE *fp;
    snprintf(path, sizeof path, "%s/%s", dir, name);
    fp = fopen(path, "rb");
    assert_non_null(fp);
    assert_int_equal(fseek(fp, 0, SEEK_END), 0);
    size = ftell(fp);
    assert_true(size >= 0);
    rewind(fp);
    data = (unsigned char *)malloc(size ? (size_t)size : 1); /* exact: ASan */
    assert_non_null(data);
    assert_int_equal(fread(data, 1, (size_t)size, fp), (size_t)size);
    fclose(fp);
    fuzz_wire_one(data, (size_t)size);
    fuzz_sealed_one(data, (size_t)size);
    fuzz_clock_one(data, (size_t)size);
    free(data);
}

/* The seeds' kinds of datagram from the encoder, through the same checks:
   the harness itself is sound on what a peer really sends. */
static gs_result keep_last(void *user, uint32_t host, const void *data, size_t size) {
    unsigned char *buf = (unsigned char *)user;
    if (host == FUZZ_HOST && size <= GS_WIRE_MAX_DATAGRAM) {
        memcpy(buf + 2, data, size);
        buf[0] = (unsigned char)size;
        buf[1] = (unsigned char)(size >> 8);
    }
    return GS_OK;
}

static void test_encoder_datagram(void **state) {
    static unsigned char buf[2 + GS_WIRE_MAX_DATAGRAM];
    unsigned char *d = buf + 2;
    fuzz_world f;
    fuzz_tally t;
    size_t n;
    (void)state;
    memset(buf, 0, sizeof buf);
    assert_int_equal(fuzz_world_create(&f, FUZZ_PEER_A, 0.0, keep_last, buf), GS_OK);
    assert_int_equal(gs_world_advance(f.w, 0.02, NULL), GS_OK);
    assert_int_equal(gs_net_update(f.net, 10.0), GS_OK);
    fuzz_world_destroy(&f);
    n = (size_t)(buf[0] | buf[1] << 8);
    assert_true(n > GS_WIRE_HEADER + 4); /* the packed small objects, sent last */
    /* the sender's run number is random per start, and the harnesses read
       the header's run word (the sealed one's nonce) and the last bytes
       (the CRC: which bit it flips): a fixed run (top bits 0: the next
       counter) and its CRC make the datagram the same at every start */
    fuzz_put32(d + 20, 0x2badcafeu);
    fuzz_put32(d + n - 4, fuzz_crc32(d, n - 4));
    fuzz_wire_one(d, n);
    /* sealed right, it is taken; again, a replay; with one bit flipped,
       forged. The last 3 bytes pick the bit (fuzz_sealed_piece): bit 0 of
       the nonce's counter (sealed bytes n - 4 + 16 on), a counter not seen
       yet, so that authentication refuses it. (A bit of the chunks or the
       tag keeps the nonce of the datagram taken: a replay; one of a header
       field is refused for that field before any decryption: the flaky
       failure, AUTH + REPLAY == 1.) */
    d[n - 1] = (unsigned char)(n + 12);
    d[n - 2] = (unsigned char)((n + 12) >> 8);
    d[n - 3] = 0;
    fuzz_sealed_run(d, n, &t);
    assert_int_equal(t.accepted, 1);
    assert_int_equal(t.why[GS_REJECT_KEY], 1);    /* as it was, in clear */
    assert_int_equal(t.why[GS_REJECT_REPLAY], 1); /* the same sealed bytes */
    assert_int_equal(t.why[GS_REJECT_AUTH], 1);   /* the flipped bit */
    assert_int_equal(t.rejected, 3);
}

/* Issue 14's remote freeze as a program of tests/fuzz_clock.c: 20 frames
   of round trips, then a datagram from host 2 with no echo and the send
   time -1e300 (then -1e12, then 0 an hour on), then snapshots that say
   GS_WIRE_MAX_TIME, frames between. It took the host to t = 1e300 (the
   harness's bounds check failed); now every time stays in bounds and no
   advance blends more than GS_MAX_TIME_CORRECTION. */
static void test_clock_attack(void **state) {
    static const uint8_t frame[4] = {0, 0, 0, 0};
    /* op 2: a datagram from host 2; b[1] its time (0: the local one, 14:
       GS_WIRE_MAX_TIME); b[2] its send time (13: -1e12, 14: -1e300);
       b[3]: no echo, no hold, objects 12, 14 and 15 */
    static const uint8_t forged[4][4] = {
        {2, 0, 14, 7 << 5}, {2, 0, 13, 7 << 5}, {2, 14, 2, 7 << 5}, {2, 14, 2, 7 << 5}};
    static const uint8_t hop[4] = {5, 7, 0, 0}; /* wall time on 1000 s */
    uint8_t prog[4 * FC_MAX_OPS];
    size_t n = 0;
    int i, k;
    (void)state;
    for (k = 0; k < 20; ++k) { memcpy(prog + n, frame, 4); n += 4; }
    for (i = 0; i < 4; ++i) {
        memcpy(prog + n, forged[i], 4);
        n += 4;
        for (k = 0; k < 3; ++k) { memcpy(prog + n, frame, 4); n += 4; }
        if (i == 1) { memcpy(prog + n, hop, 4); n += 4; }
    }
    assert_true(n <= sizeof prog);
    fuzz_clock_one(prog, n);
}

static int by_name(const void *a, const void *b) {
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* Lists the directory, sorted, hidden files left out. */
static int list_inputs(void) {
    DIR *d = opendir(dir);
    struct dirent *e;
    int n = 0;
    if (!d) {
        fprintf(stderr, "test_fuzz_regress: cannot open %s\n", dir);
        return -1;
    }
    while ((e = readdir(d)) != NULL && n < MAX_FILES) {
        size_t len = strlen(e->d_name);
        if (e->d_name[0] == '.') continue;
        names[n] = (char *)malloc(len + 1);
        if (!names[n]) break;
        memcpy(names[n], e->d_name, len + 1);
        n++;
    }
    closedir(d);
    qsort(names, (size_t)n, sizeof names[0], by_name);
    return n;
}

int main(void) {
    const char *env = getenv("GS_FUZZ_REGRESSIONS");
    const char *slash = strrchr(__FILE__, '/');
    int n, i, failed;
    if (env) snprintf(dir, sizeof dir, "%s", env);
    else if (slash) snprintf(dir, sizeof dir, "%.*s/fuzz-regressions", (int)(slash - __FILE__), __FILE__);
    else snprintf(dir, sizeof dir, "fuzz-regressions");
    n = list_inputs();
    if (n < 0) return 1;
    memset(tests, 0, sizeof tests);
    tests[0].name = "test_encoder_datagram";
    tests[0].test_func = test_encoder_datagram;
    tests[1].name = "test_clock_attack";
    tests[1].test_func = test_clock_attack;
    for (i = 0; i < n; ++i) {
        tests[i + 2].name = names[i];
        tests[i + 2].test_func = replay;
        tests[i + 2].initial_state = names[i];
    }
    failed = _cmocka_run_group_tests("test_fuzz_regress", tests, (size_t)n + 2, NULL, NULL);
    for (i = 0; i < n; ++i) free(names[i]);
    return failed;
}
