/* net_helpers.h - the tests' short ways to make a net on the simnet, on
   UDP or on a transport of the test's own: gs_net_create on the transport
   that gs_simnet_transport, or gs_udp_create and gs_udp_transport, or the
   test fills (tests/test_transport.c tests those calls one by one), and a
   free loopback address for UDP. Include after ghostsim.h. */
#ifndef GS_TEST_NET_HELPERS_H
#define GS_TEST_NET_HELPERS_H

#include <stdio.h>
#include <string.h>
#ifndef GHOSTSIM_NO_UDP
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>
#endif

#include "helpers.h"

/* The simulation times of the snapshots a datagram holds (one per
   snapshot: its first chunk's, acknowledgements left out), at most max of
   them in t; returns how many, 0 for one that does not decode. */
static GS_TEST_UNUSED int wire_snapshot_times(const void *data, size_t size, double *t, int max) {
    static gs_wire_view v; /* large; one test at a time */
    gs_reject why;
    int i, n = 0;
    if (gs_wire_decode((const unsigned char *)data, size, &v, &why) != GS_OK) return 0;
    for (i = 0; i < v.chunk_count && n < max; ++i)
        if (v.chunks[i].index == 0 && !(v.chunks[i].flags & GS_WIRE_CHUNK_ACK)) t[n++] = v.chunks[i].time;
    return n;
}

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

/* The paper scene small enough for a test under ASan, in w: an 8 x 8
   cloth, a sphere, two probes (no ghosts yet). */
static GS_TEST_UNUSED gs_result test_small_scene(gs_world *w, gs_scene *sc) {
    gs_scene_desc sd = gs_scene_desc_default();
    sd.cloth_n = 8;
    sd.sphere_count = 1;
    sd.probe_count = 2;
    return gs_scene_create(w, &sd, sc);
}

/* Two hosts (ids 1 and 2) of a small paper scene on sim: a 6 x 6 cloth,
   2 spheres and a probe each, client/server ghosts, the spheres landed
   (0.5 s), each joined; wd: their world desc but for the host id. The
   first failure, or GS_OK. test_scene_pair_rule: host k+1's ghosts
   under `weight` with users[k] (users NULL: no user). */
static GS_TEST_UNUSED gs_result test_scene_pair_rule(gs_simnet *sim, const gs_world_desc *wd,
                                                     gs_world *w[2], gs_scene sc[2],
                                                     gs_weight_fn weight, void *const *users) {
    gs_scene_desc sd = gs_scene_desc_default();
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_net *net; /* the world owns it */
    gs_result r = GS_OK;
    int k;
    sd.cloth_n = 6;
    sd.sphere_count = 2;
    sd.probe_count = 2;
    gd.weight = weight;
    for (k = 0; k < 2 && r == GS_OK; ++k) {
        gs_world_desc d = *wd;
        d.host_id = (uint32_t)k + 1;
        gd.weight_user = users ? users[k] : NULL;
        r = gs_world_create(&d, &w[k]);
        if (r == GS_OK) r = gs_scene_create(w[k], &sd, &sc[k]);
        if (r == GS_OK) r = gs_scene_attach_ghosts(&sc[k], &gd);
        if (r == GS_OK) r = gs_world_advance(w[k], 0.5, NULL); /* spheres land */
        if (r == GS_OK) r = test_join(sim, w[k], NULL, &net);
    }
    return r;
}
static GS_TEST_UNUSED gs_result test_scene_pair(gs_simnet *sim, const gs_world_desc *wd,
                                                gs_world *w[2], gs_scene sc[2]) {
    return test_scene_pair_rule(sim, wd, w, sc, gs_weight_cs, NULL);
}

/* The world's net on a transport of the test's own that has only send
   (desc NULL: the defaults; send and user replace its transport). */
static GS_TEST_UNUSED gs_result send_only_net(gs_world *w, const gs_net_desc *desc,
                                              gs_result (*send)(void *user, uint32_t host,
                                                                const void *data, size_t size),
                                              void *user, gs_net **out) {
    gs_net_desc nd = desc ? *desc : gs_net_desc_default();
    memset(&nd.transport, 0, sizeof nd.transport);
    nd.transport.send = send;
    nd.transport.user = user;
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

/* A port of the loopback that is free now (the kernel's choice: port 0),
   written as "127.0.0.1:PORT" or (v6) "[::1]:PORT" into buf; fixed ports
   collide with other test runs on a shared machine. Returns the port, 0
   if there is no such loopback. */
static GS_TEST_UNUSED int loopback_addr(int v6, char *buf, size_t size) {
    struct sockaddr_storage a;
    socklen_t len = sizeof a;
    int fd = socket(v6 ? AF_INET6 : AF_INET, SOCK_DGRAM, 0), port = 0;
    if (fd < 0) return 0;
    memset(&a, 0, sizeof a);
    if (v6) {
        struct sockaddr_in6 *a6 = (struct sockaddr_in6 *)(void *)&a;
        a6->sin6_family = AF_INET6;
        a6->sin6_addr = in6addr_loopback;
    } else {
        struct sockaddr_in *a4 = (struct sockaddr_in *)(void *)&a;
        a4->sin_family = AF_INET;
        a4->sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    }
    if (bind(fd, (struct sockaddr *)&a, v6 ? sizeof(struct sockaddr_in6)
                                           : sizeof(struct sockaddr_in)) == 0 &&
        getsockname(fd, (struct sockaddr *)&a, &len) == 0)
        port = ntohs(v6 ? ((struct sockaddr_in6 *)(void *)&a)->sin6_port
                        : ((struct sockaddr_in *)(void *)&a)->sin_port);
    close(fd);
    if (port) snprintf(buf, size, v6 ? "[::1]:%d" : "127.0.0.1:%d", port);
    return port;
}
#endif

#endif
