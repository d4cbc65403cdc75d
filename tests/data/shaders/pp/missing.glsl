#include "pp/missing_file.glsl"
