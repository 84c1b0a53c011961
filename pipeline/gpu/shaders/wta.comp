#version 450
// Winner-takes-all on the summed costs, per pixel. Left view: the lowest sum (lowest d on ties), rejected
// (-1) when another disparity more than 1 away has sum * (100 - uniqueness) < best * 100, or when the
// pixel is closer than min_disparity + num_disparities - 1 to the left edge (part of the band has no
// match); sub-pixel by a parabola through the sums at d-1, d, d+1, in 1/64 px, integer arithmetic:
//   d64 = (min_disparity + d) 64 + trunc(((S[d-1] - S[d+1]) 64 + den) / (2 den)), den = max(S[d-1] + S[d+1] - 2 S[d], 1)
// Right view (for the left-right check): integer disparity minimising S(xr + min_disparity + d, d), -1 if none.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Sum { uint sum[]; };
layout(std430, binding = 1) writeonly buffer DispL { int disp_l[]; };
layout(std430, binding = 2) writeonly buffer DispR { int disp_r[]; };
layout(push_constant) uniform Params { int width, height, min_disparity, num_disparities, uniqueness; } pc;

uint cost(int x, int y, int d) {
  const uint w = sum[(y * pc.width + x) * (pc.num_disparities / 2) + d / 2];
  return (d & 1) == 0 ? (w & 0xFFFFu) : (w >> 16);
}

void main() {
  const int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  if (x >= pc.width || y >= pc.height) return;
  const int D = pc.num_disparities;
  int out_l = -1;
  if (x >= pc.min_disparity + D - 1) {
    uint best = 0xFFFFFFFFu;
    int bd = 0;
    for (int d = 0; d < D; ++d) {
      const uint s = cost(x, y, d);
      if (s < best) { best = s; bd = d; }
    }
    bool unique = true;
    for (int d = 0; d < D; ++d) {
      if (abs(d - bd) > 1 && cost(x, y, d) * uint(100 - pc.uniqueness) < best * 100u) unique = false;
    }
    if (unique) {
      out_l = (pc.min_disparity + bd) * 64;
      if (bd > 0 && bd < D - 1) {
        const int a = int(cost(x, y, bd - 1)), b = int(cost(x, y, bd + 1));
        const int den = max(a + b - 2 * int(best), 1);
        const int n = (a - b) * 64 + den;
        out_l += n >= 0 ? n / (2 * den) : -((-n) / (2 * den));
      }
    }
  }
  disp_l[y * pc.width + x] = out_l;

  int out_r = -1;
  uint best_r = 0xFFFFFFFFu;
  for (int d = 0; d < D && x + pc.min_disparity + d < pc.width; ++d) {
    const uint s = cost(x + pc.min_disparity + d, y, d);
    if (s < best_r) { best_r = s; out_r = pc.min_disparity + d; }
  }
  disp_r[y * pc.width + x] = out_r;
}
