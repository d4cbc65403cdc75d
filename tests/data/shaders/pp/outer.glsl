// includes a broken file
#include "pp/broken.glsl"
