#include "pp/leaf.glsl"
float mid_value() {
    return leaf_value() + 1.0;
}
