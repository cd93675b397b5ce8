/* fuzz_sealed.c - libFuzzer harness over the receiving side of a keyed net
   (GHOSTSIM_SODIUM): the cheap checks before decryption, the replay
   window, authentication, then decode, validation and blend of what it
   opened.

   Inputs are those of tests/fuzz_wire.c (datagrams in clear, cut before
   every "GSIM"), so the two harnesses share their seeds and regressions.
   The world is tests/fuzz_world.h's with a key. For each datagram:
     1. Delivered as it is: a keyed net takes no datagram in clear, and no
        sealed one that was not sealed under its key: it is refused.
     2. Sealed by the harness itself, as >>wire describes it (the flag, the
        chunks encrypted, nonce and tag; libsodium directly): its own
        sealer, so that a mistake shared with the library's would not hide.
        Two bits of the header's run word steer the nonce, so that
        mutations reach the replay window: the next counter (most), a new
        run of the sender (a later epoch, the counter from 0), a nonce of
        an earlier run, or a counter up to 127 back.
        A datagram sealed right never fails authentication. It is taken
        only if its chunks in clear decode (checked as in fuzz_wire.c);
        refused, it is refused for decode's reason or for one the net
        checks first (session, sender, replay window, rate).
     3. The same sealed bytes again: a replay, refused.
     4. The sealed bytes with one bit flipped (where, the input decides):
        tampered, refused.
     5. The world advances 4 ms and the net sends what is due: every
        datagram it sends is sealed, opens under the key and decodes.
   At the end, the checks of fuzz_wire.c: finite states and statistics,
   counters that add up to what the harness delivered.

   Build: make fuzz (runs this after fuzz_wire). tests/test_fuzz_regress.c
   replays every regression and seed through both harnesses. */
#ifndef FUZZ_NO_ENTRY
#define FUZZ_NO_ENTRY /* fuzz_wire.c's entry point: not in this binary */
#define FUZZ_SEALED_ENTRY
#endif
#include "fuzz_wire.c"

#include <sodium.h>

#define FUZZ_MAX_SEAL 12288 /* bytes of a datagram the harness seals (fuzz_run.sh's
                              -max_len: no longer input reaches here from it) */

/* The harness's nonce: a run (epoch, salt) and a counter, as a sender's. */
typedef struct fuzz_sealer {
    unsigned char key[GS_WIRE_KEY_BYTES];
    uint64_t epoch, salt, counter;
} fuzz_sealer;

static void fuzz_put64(unsigned char *p, uint64_t v) {
    fuzz_put32(p, (uint32_t)v);
    fuzz_put32(p + 4, (uint32_t)(v >> 32));
}

static void fuzz_sealer_init(fuzz_sealer *s) {
    int i;
    for (i = 0; i < GS_WIRE_KEY_BYTES; ++i) s->key[i] = (unsigned char)(7 * i + 1);
    s->epoch = 1790000000000000ull; /* microseconds since 1970: late 2026 */
    s->salt = 0x9e3779b97f4a7c15ull;
    s->counter = 0;
}

/* The nonce for the next datagram, as the header's run word steers it
   (bits 6-7 of its top byte; the byte below it says how far back). */
static void fuzz_nonce(fuzz_sealer *s, const unsigned char *header, unsigned char *nonce) {
    uint64_t epoch = s->epoch, counter;
    switch (header[23] >> 6) {
    case 1: /* a new run of the sender */
        epoch = ++s->epoch;
        s->salt = s->salt * 6364136223846793005ull + 1442695040888963407ull;
        s->counter = 0;
        counter = 0;
        break;
    case 2: /* a nonce of an earlier run */
        epoch = s->epoch - 1;
        counter = ++s->counter;
        break;
    case 3: /* back in the current run: a replay, or older than the window */
        counter = s->counter > (header[22] & 0x7fu) ? s->counter - (header[22] & 0x7fu) : 0;
        break;
    default:
        counter = ++s->counter;
    }
    fuzz_put64(nonce, epoch);
    fuzz_put64(nonce + 8, s->salt);
    fuzz_put64(nonce + 16, counter);
}

/* Seals the clear datagram in[0, n) (its last 4 bytes, the CRC, dropped)
   into out: header with the flag set (authenticated), chunks encrypted,
   nonce, tag. Returns the sealed size. */
static size_t fuzz_seal(fuzz_sealer *s, const unsigned char *in, size_t n, unsigned char *out) {
    size_t body = n - 4 - GS_WIRE_HEADER;
    unsigned char *nonce = out + n - 4, *tag = nonce + GS_WIRE_NONCE_BYTES;
    unsigned long long taglen = 0;
    memcpy(out, in, n - 4);
    out[5] |= GS_WIRE_FLAG_SEALED;
    fuzz_nonce(s, out, nonce);
    FUZZ_CHECK(crypto_aead_xchacha20poly1305_ietf_encrypt_detached(
                   out + GS_WIRE_HEADER, tag, &taglen, out + GS_WIRE_HEADER, body, out,
                   GS_WIRE_HEADER, NULL, nonce, s->key) == 0);
    return n - 4 + GS_WIRE_SEAL_TRAILER;
}

/* A sealed datagram opened into a clear one (flag off, CRC made): 0 if it
   does not authenticate. */
static int fuzz_open(const fuzz_sealer *s, const unsigned char *in, size_t n,
                     unsigned char *out, size_t *out_n) {
    size_t end = n - GS_WIRE_SEAL_TRAILER;
    if (n < GS_WIRE_HEADER + GS_WIRE_SEAL_TRAILER) return 0;
    memcpy(out, in, GS_WIRE_HEADER);
    if (crypto_aead_xchacha20poly1305_ietf_decrypt_detached(
            out + GS_WIRE_HEADER, NULL, in + GS_WIRE_HEADER, end - GS_WIRE_HEADER,
            in + end + GS_WIRE_NONCE_BYTES, in, GS_WIRE_HEADER, in + end, s->key) != 0)
        return 0;
    out[5] &= (unsigned char)~GS_WIRE_FLAG_SEALED;
    fuzz_put32(out + end, fuzz_crc32(out, end));
    *out_n = end + 4;
    return 1;
}

/* What the keyed world sends: sealed under the key, and sound inside. */
typedef struct fuzz_keyed {
    fuzz_tally t;
    fuzz_sealer s;
} fuzz_keyed;

static gs_result fuzz_sealed_send(void *user, uint32_t host, const void *data, size_t size) {
    fuzz_keyed *k = (fuzz_keyed *)user;
    static unsigned char clear[GS_WIRE_MAX_DATAGRAM];
    static gs_wire_view v;
    const unsigned char *b = (const unsigned char *)data;
    size_t n = 0;
    gs_reject why;
    FUZZ_CHECK(host == FUZZ_PEER_A || host == FUZZ_PEER_B);
    FUZZ_CHECK(size <= GS_WIRE_MAX_DATAGRAM && size >= GS_WIRE_HEADER + GS_WIRE_SEAL_TRAILER);
    FUZZ_CHECK(b[5] == GS_WIRE_FLAG_SEALED);
    FUZZ_CHECK(fuzz_open(&k->s, b, size, clear, &n));
    FUZZ_CHECK(gs_wire_decode(clear, n, &v, &why) == GS_OK);
    FUZZ_CHECK(v.header.session == FUZZ_SESSION && v.header.sender == FUZZ_HOST);
    k->t.sent++;
    return GS_OK;
}

/* Refused before the datagram is opened, or by the net after decoding:
   reasons that do not depend on the chunks. */
static int fuzz_net_first(gs_reject r) {
    return r == GS_REJECT_SESSION || r == GS_REJECT_SENDER || r == GS_REJECT_REPLAY ||
           r == GS_REJECT_RATE;
}

/* Delivers an exact-size copy and tallies the outcome. */
static gs_result fuzz_sealed_deliver(fuzz_world *f, fuzz_tally *t, const unsigned char *src,
                                     size_t size, double now, gs_reject *why) {
    unsigned char *buf = (unsigned char *)malloc(size ? size : 1);
    gs_result r;
    FUZZ_CHECK(buf != NULL);
    if (size) memcpy(buf, src, size);
    *why = GS_REJECT_COUNT;
    r = gs_net_deliver(f->net, buf, size, now, why);
    FUZZ_CHECK(r == GS_OK || r == GS_ERR_REJECTED);
    fuzz_count(t, r, *why, buf, size);
    free(buf);
    return r;
}

/* Steps 2-4 for one clear datagram of n bytes (header + CRC <= n <=
   FUZZ_MAX_SEAL). */
static void fuzz_sealed_piece(fuzz_world *f, fuzz_keyed *k, const unsigned char *piece,
                              size_t n, double now) {
    static unsigned char clear[FUZZ_MAX_SEAL], sealed[FUZZ_MAX_SEAL + GS_WIRE_SEAL_TRAILER];
    gs_reject dec_why, why, again;
    size_t size, flip;
    int ok;
    gs_result r;
    /* the clear form the sealed one must behave as: flag off, CRC right */
    memcpy(clear, piece, n);
    clear[5] &= (unsigned char)~GS_WIRE_FLAG_SEALED;
    fuzz_put32(clear + n - 4, fuzz_crc32(clear, n - 4));
    ok = fuzz_decode(clear, n, &dec_why);
    size = fuzz_seal(&k->s, piece, n, sealed);
    r = fuzz_sealed_deliver(f, &k->t, sealed, size, now, &why);
    if (r == GS_OK) {
        FUZZ_CHECK(ok && size <= GS_WIRE_MAX_DATAGRAM);
    } else {
        FUZZ_CHECK(why != GS_REJECT_AUTH && why != GS_REJECT_CHECKSUM && why != GS_REJECT_KEY);
        if (size > GS_WIRE_MAX_DATAGRAM) FUZZ_CHECK(why == GS_REJECT_LAYOUT);
        else if (ok) FUZZ_CHECK(!fuzz_decode_reason(why) || (k->t.window && why == GS_REJECT_TIME));
        else FUZZ_CHECK(why == dec_why || fuzz_net_first(why));
    }
    r = fuzz_sealed_deliver(f, &k->t, sealed, size, now, &again);
    FUZZ_CHECK(r == GS_ERR_REJECTED);
    flip = (size_t)(piece[n - 1] | piece[n - 2] << 8) % size;
    sealed[flip] ^= (unsigned char)(1u << (piece[n - 3] & 7));
    r = fuzz_sealed_deliver(f, &k->t, sealed, size, now, &again);
    FUZZ_CHECK(r == GS_ERR_REJECTED);
}

/* Runs one input; *tally (if not NULL) gets what was delivered. */
static void fuzz_sealed_run(const uint8_t *data, size_t size, fuzz_tally *tally) {
    static fuzz_keyed k;
    fuzz_world f;
    gs_reject why;
    double now = 10.0;
    size_t start = 0;
    int pieces = 0;
    memset(&k, 0, sizeof k);
    fuzz_sealer_init(&k.s);
    k.t.window = (int)(size % 2);
    FUZZ_CHECK(sodium_init() >= 0);
    FUZZ_CHECK(fuzz_world_create_keyed(&f, FUZZ_HOST, k.t.window ? 100.0 : 0.0, k.s.key,
                                       fuzz_sealed_send, &k) == GS_OK);
    while (start < size && pieces++ < FUZZ_MAX_PIECES) {
        size_t end = fuzz_next_piece(data, size, start), n = end - start;
        now += FUZZ_STEP;
        FUZZ_CHECK(fuzz_sealed_deliver(&f, &k.t, data + start, n, now, &why) == GS_ERR_REJECTED);
        if (n >= GS_WIRE_HEADER + 4 && n <= FUZZ_MAX_SEAL)
            fuzz_sealed_piece(&f, &k, data + start, n, now);
        fuzz_step(&f, now);
        start = end;
    }
    fuzz_finish(&f, &k.t, now);
    if (tally) *tally = k.t;
}

int fuzz_sealed_one(const uint8_t *data, size_t size);
int fuzz_sealed_one(const uint8_t *data, size_t size) {
    fuzz_sealed_run(data, size, NULL);
    return 0;
}

#ifdef FUZZ_SEALED_ENTRY
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    return fuzz_sealed_one(data, size);
}
#endif
