/* net_helpers.h - the tests' short ways to make a net on the simnet or on
   UDP: gs_net_create on the transport that gs_simnet_transport, or
   gs_udp_create and gs_udp_transport, fill (tests/test_transport.c tests
   those calls one by one). Include after ghostsim.h. */
#ifndef GS_TEST_NET_HELPERS_H
#define GS_TEST_NET_HELPERS_H

#if defined(__GNUC__) || defined(__clang__)
#define GS_TEST_UNUSED __attribute__((unused))
#else
#define GS_TEST_UNUSED
#endif

/* The world's net on the simnet (desc NULL: the defaults; its transport
   is filled here): the host is linked to every host joined before. */
static GS_TEST_UNUSED gs_result test_join(gs_simnet *sim, gs_world *w, const gs_net_desc *desc,
                                          gs_net **out) {
    gs_net_desc nd = desc ? *desc : gs_net_desc_default();
    gs_result r;
    if (out) *out = NULL;
    r = gs_simnet_transport(sim, &nd.transport);
    if (r != GS_OK) return r;
    return gs_net_create(w, &nd, out);
}

#ifndef GHOSTSIM_NO_UDP
/* The world's net on a UDP socket bound to ud->bind (nd NULL: the
   defaults); the net owns the socket (gs_net_destroy closes it). */
static GS_TEST_UNUSED gs_result test_udp_open(gs_world *w, const gs_udp_desc *ud,
                                              const gs_net_desc *nd, gs_net **out) {
    gs_net_desc d = nd ? *nd : gs_net_desc_default();
    gs_udp *u;
    gs_result r;
    if (out) *out = NULL;
    r = gs_udp_create(w, ud, &u);
    if (r != GS_OK) return r;
    r = gs_udp_transport(u, &d.transport);
    if (r == GS_OK) r = gs_net_create(w, &d, out);
    if (r != GS_OK) gs_udp_close(u);
    return r;
}
#endif

#endif
