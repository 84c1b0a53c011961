#version 450
// Cubic B-spline coefficients of both images (gl_GlobalInvocationID.z: 0 left, 1 right), one invocation
// per pixel. The interpolation prefilter (inverse of [1 4 1] / 6) has the impulse response
// sqrt(3) z^|j|, z = sqrt(3) - 2; truncated at |j| <= 18 (|z|^18 < 1e-10) on the image mirrored at its
// ends (whole-sample symmetry, as the CPU DIC's recursive filter), it is a 37-tap filter that runs in
// parallel instead of two sequential passes per row. Float, in the order of dic_reference.cpp.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Left { uint left_px[]; };
layout(std430, binding = 1) readonly buffer Right { uint right_px[]; };
layout(std430, binding = 2) writeonly buffer CoefL { float coef_l[]; };
layout(std430, binding = 3) writeonly buffer CoefR { float coef_r[]; };
layout(push_constant) uniform Params { int width, height, words_per_row; } pc;
#include "common.glsl"

const float kZ = -0.26794919243112270;  // sqrt(3) - 2
const float kGain = 1.7320508075688772;  // sqrt(3)

// Column k of the image mirrored about its first and last pixels, repeated with period 2 (width - 1).
int mirrored(int k) {
  const int n = pc.width;
  if (n == 1) return 0;
  const int period = 2 * (n - 1);
  // GLSL leaves % undefined for a negative operand (NVIDIA's result differs from C's), so k is made
  // non-negative first: the filter reaches 18 columns left of 0, and 32 periods are at least 64.
  const int m = (k + 32 * period) % period;
  return m < n ? m : period - m;
}

float grey(bool right, int x, int y) {
  const int i = y * pc.words_per_row + (x >> 2);
  return float(pixel_at(right ? right_px[i] : left_px[i], x));
}

void main() {
  const int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  const bool right = gl_GlobalInvocationID.z == 1u;
  if (x >= pc.width || y >= pc.height) return;
  precise float w = kGain;
  precise float sum = w * grey(right, x, y);
  for (int j = 1; j <= 18; ++j) {
    w = w * kZ;
    sum = sum + w * (grey(right, mirrored(x - j), y) + grey(right, mirrored(x + j), y));
  }
  if (right) coef_r[y * pc.width + x] = sum; else coef_l[y * pc.width + x] = sum;
}
