/* Compiled by `make compile-checks` as C99 and C++11, gcc and clang, with
   and without GHOSTSIM_STATIC: the header and its implementation must build
   without a warning under -Wall -Wextra -Wpedantic -Werror. */
/* The first include below pulls in system headers before the
   implementation asks for POSIX, so this file asks for it (the header's
   documented rule); tests/compile_one.c checks the single include. */
#define _POSIX_C_SOURCE 200809L
#include "ghostsim.h" /* twice: the include guard must hold */
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"

int gs_compile_check(void);
int gs_compile_check(void) {
    gs_world *w = NULL;
    gs_result r = gs_world_create(NULL, &w);
    gs_world_destroy(w);
    return (int)r;
}
