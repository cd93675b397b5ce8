/* helpers.h - what the tests' helper headers (net_helpers.h,
   alloc_helpers.h, world_helpers.h) share: their functions are static, and
   a test that uses only some of them must not warn about the rest. */
#ifndef GS_TEST_HELPERS_H
#define GS_TEST_HELPERS_H

#if defined(__GNUC__) || defined(__clang__)
#define GS_TEST_UNUSED __attribute__((unused))
#else
#define GS_TEST_UNUSED
#endif

#endif
