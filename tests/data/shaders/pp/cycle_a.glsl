#include "pp/cycle_b.glsl"
