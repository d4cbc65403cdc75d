// Orthonormal frames: a basis from one unit vector (Duff et al. 2017), and to/from local.
//
// Sampling routines work in a local frame with +z along the normal; a Frame carries
// directions between that frame and the frame its axes are expressed in (world or
// render space): frame_to_local(f, v) = local_from_world * v, frame_from_local(f, v)
// = world_from_local * v.

// Right-handed orthonormal basis: cross(x, y) = z.
struct Frame {
    vec3 x;
    vec3 y;
    vec3 z;
};

// Two unit vectors b1, b2 completing the unit vector n to a right-handed orthonormal
// basis (b1, b2, n), without branches on n: Duff, Burgess, Christensen, Hery, Kensler,
// Liani, Villemin, "Building an Orthonormal Basis, Revisited", JCGT 6(1), 2017, listing 3.
// Continuous everywhere except across the plane n.z = 0 (the sign flip); accurate to a
// few ulps for every unit n, including n = (0, 0, -1).
void branchless_onb(vec3 n, out vec3 b1, out vec3 b2) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;  // copysign(1, n.z); GLSL sign(0) would be 0
    float a = -1.0 / (s + n.z);
    float b = n.x * n.y * a;
    b1 = vec3(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    b2 = vec3(b, s + n.y * n.y * a, -n.y);
}

// The frame whose z axis is the unit vector n (x and y from branchless_onb).
Frame frame_from_z(vec3 n) {
    Frame f;
    branchless_onb(n, f.x, f.y);
    f.z = n;
    return f;
}

// The frame with the given orthonormal x and y axes; z = cross(x, y).
Frame frame_from_xy(vec3 x, vec3 y) {
    return Frame(x, y, cross(x, y));
}

// Coordinates of v in the frame (local, +z = f.z): local_from_world * v.
vec3 frame_to_local(Frame f, vec3 v) {
    return vec3(dot(v, f.x), dot(v, f.y), dot(v, f.z));
}

// The vector whose local coordinates are v: world_from_local * v.
vec3 frame_from_local(Frame f, vec3 v) {
    return v.x * f.x + v.y * f.y + v.z * f.z;
}
