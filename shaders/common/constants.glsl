// Mathematical constants shared by every shader.
const float kPi = 3.14159265358979323846;
const float kTwoPi = 6.28318530717958647692;
const float kInvPi = 0.31830988618379067154;
const float kInvTwoPi = 0.15915494309189533577;
const float kInvFourPi = 0.07957747154594766788;
const float kPiOver2 = 1.57079632679489661923;
const float kPiOver4 = 0.78539816339744830962;
const float kSqrt2 = 1.41421356237309504880;
const float kInfinity = uintBitsToFloat(0x7F800000u);
// The largest float below 1: uniform numbers live in [0, kOneMinusEpsilon].
const float kOneMinusEpsilon = 0.99999994039535522461;
// Machine epsilon / 2 for float32 (pbrt's gamma bounds).
const float kMachineEpsilon = 5.96046447753906250000e-8;
// The growth of a box's far distance that keeps rounding from rejecting a box a ray
// touches: 1 + 2 gamma(3) (Ize 2013, "Robust BVH Ray Traversal"), and a margin.
const float kRobustFar = 1.0 + 2.0 * 3.0 * kMachineEpsilon / (1.0 - 3.0 * kMachineEpsilon) + 1e-7;
