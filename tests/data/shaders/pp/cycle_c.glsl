
#include "pp/cycle_a.glsl"
