// a file with a syntax error on line 5
#include "pp/leaf.glsl"
float broken_value()
{
    return leaf_value() +* 2.0;
}
