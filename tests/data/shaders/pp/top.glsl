#include "pp/leaf.glsl"
#include "pp/mid.glsl"
float top_value() {
    return mid_value() + leaf_value();
}
