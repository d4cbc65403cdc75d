#include "pp/cycle_c.glsl"
