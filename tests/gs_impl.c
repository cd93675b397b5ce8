#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"
