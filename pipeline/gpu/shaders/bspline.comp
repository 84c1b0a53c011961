#version 450
// Cubic B-spline coefficients of every row of both images (gl_GlobalInvocationID.y: 0 left, 1 right), one
// invocation per row: Unser's recursive prefilter with mirror boundary, in float, as dic_reference.cpp:
//   c[k] = 6 in[k]; causal initial value: the mirrored sum truncated at 18 terms (z^k < 1e-10);
//   c[k] = z c[k-1] + c[k]; c[n-1] = z / (z^2 - 1) (z c[n-2] + c[n-1]); c[k] = z (c[k+1] - c[k]).
// Rows of one pixel keep the pixel (a constant's spline).
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Left { uint left_px[]; };
layout(std430, binding = 1) readonly buffer Right { uint right_px[]; };
layout(std430, binding = 2) buffer CoefL { float coef_l[]; };
layout(std430, binding = 3) buffer CoefR { float coef_r[]; };
layout(push_constant) uniform Params { int width, height, words_per_row; } pc;
#include "common.glsl"

const float z = -0.26794919243112270;  // sqrt(3) - 2

void store(bool right, int i, float v) { if (right) coef_r[i] = v; else coef_l[i] = v; }
float load(bool right, int i) { return right ? coef_r[i] : coef_l[i]; }

void main() {
  const int y = int(gl_GlobalInvocationID.x);
  const bool right = gl_GlobalInvocationID.y == 1u;
  if (y >= pc.height) return;
  const int n = pc.width, row = y * n;
  for (int k = 0; k < n; ++k) {
    const int i = y * pc.words_per_row + (k >> 2);
    store(right, row + k, 6.0 * float(pixel_at(right ? right_px[i] : left_px[i], k)));
  }
  if (n < 2) return;
  // Written back and read again: the buffers are the scratch (row-sequential, one invocation per row).
  precise float sum = load(right, row);
  precise float zk = z;
  for (int k = 1; k < min(n, 18); ++k) {
    sum = zk * load(right, row + k) + sum;
    zk *= z;
  }
  store(right, row, sum);
  precise float previous = sum;
  for (int k = 1; k < n; ++k) {
    previous = z * previous + load(right, row + k);
    store(right, row + k, previous);
  }
  previous = (z / (z * z - 1.0)) * (z * load(right, row + n - 2) + previous);
  store(right, row + n - 1, previous);
  for (int k = n - 2; k >= 0; --k) {
    previous = z * (previous - load(right, row + k));
    store(right, row + k, previous);
  }
}
