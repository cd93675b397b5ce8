/* Compiled by `make compile-checks` like compile_check.c: the usual
   implementation file, one include and nothing else, with no feature macro
   on the command line. */
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"

int main(void) { return gs_world_desc_default().host_id == 1 ? 0 : 1; }
