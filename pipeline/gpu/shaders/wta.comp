#version 450
#extension GL_EXT_control_flow_attributes : require
// Winner-takes-all on the summed path costs. Left view: the lowest sum (lowest d on ties), rejected (-1)
// when another disparity more than 1 away has sum * (100 - uniqueness) < best * 100, or when the pixel is
// closer than min_disparity + num_disparities - 1 to the left edge (part of the band has no match);
// sub-pixel by a parabola through the sums at d-1, d, d+1, in 1/64 px, integer arithmetic:
//   d64 = (min_disparity + d) 64 + trunc(((S[d-1] - S[d+1]) 64 + den) / (2 den)), den = max(S[d-1] + S[d+1] - 2 S[d], 1)
// Right view (for the left-right check): the d minimising S(xr + min_disparity + d, d), lowest d on ties.
//
// Workgroup (segment of kSegment pixels, row), kParts invocations per pixel: it adds the directions' byte
// costs (aggregate.comp) of its pixels into 16-bit sums in shared memory; each invocation scans every
// kParts-th disparity of its pixel, and the parts combine through shared atomics (the best as the key
// sum * 512 + d, so the lowest sum and then the lowest d win, as the reference's scan). For the right view
// every (pixel x, d) of the segment offers the key S(x, d) * 512 + d to the right pixel
// xr = x - min_disparity - d; the smallest key wins, first within the workgroup (shared atomicMin), then
// across workgroups (atomicMin into right_key, which the host fills with 0xFFFFFFFF = none). Sums are at
// most 8 * 255 < 2^11, so keys fit 20 bits.
layout(local_size_x = 128) in;
// aggregate.comp's, read four words at a time (the host makes words a multiple of 4).
layout(std430, binding = 0) readonly buffer PathCost { uvec4 w[]; } path_cost[8];
layout(std430, binding = 1) writeonly buffer DispL { int disp_l[]; };
layout(std430, binding = 2) buffer RightKey { uint right_key[]; };
layout(push_constant) uniform Params { int width, height, min_disparity, num_disparities, uniqueness, paths, words; } pc;

const int kMaxDisparities = 512;
const int kSegment = 16, kParts = 8;
// One word of padding per pixel: invocations reading the same d of different pixels hit different banks.
shared uint sums[kSegment][kMaxDisparities / 2 + 1];  // d = 2i in the low half of word i, 2i + 1 in the high
shared uint right_best[kSegment + kMaxDisparities - 1];
shared uint left_best[kSegment];  // key sum * 512 + d
shared uint ambiguous[kSegment];  // nonzero: the uniqueness test failed

uint sum_at(int p, int d) { return (sums[p][d >> 1] >> (16u * uint(d & 1))) & 0xFFFFu; }

void main() {
  const int t = int(gl_LocalInvocationID.x);
  const int W = pc.width, D = pc.num_disparities;
  const int x0 = int(gl_WorkGroupID.x) * kSegment, y = int(gl_WorkGroupID.y);
  const int n = min(kSegment, W - x0);  // pixels of this segment
  const int span = n + D - 1;            // right pixels its pairs reach, from base on
  const int base = x0 - pc.min_disparity - (D - 1);
  for (int i = t; i < span; i += 128) right_best[i] = 0xFFFFFFFFu;
  if (t < kSegment) { left_best[t] = 0xFFFFFFFFu; ambiguous[t] = 0u; }
  const int quads = pc.words / 4;
  for (int i = t; i < n * quads; i += 128) {
    const int p = i / quads, quad = i - p * quads;
    const int at = (y * W + x0 + p) * quads + quad;
    uvec4 even = uvec4(0u), odd = uvec4(0u);  // bytes 0 and 2, and 1 and 3, of each word, added as 16-bit halves
    [[unroll]] for (int k = 0; k < 8; ++k) {  // unrolled: the loads are in flight together
      if (k < pc.paths) {
        const uvec4 v = path_cost[k].w[at];
        even += v & 0x00FF00FFu;
        odd += (v >> 8) & 0x00FF00FFu;
      }
    }
    [[unroll]] for (int c = 0; c < 4; ++c) {
      const int word = 4 * quad + c;
      sums[p][2 * word] = (even[c] & 0xFFFFu) | (odd[c] << 16);          // d = 4 word, 4 word + 1
      sums[p][2 * word + 1] = (even[c] >> 16) | (odd[c] & 0xFFFF0000u);  // d = 4 word + 2, 4 word + 3
    }
  }
  barrier();

  const int p = t / kParts, part = t % kParts, x = x0 + p;
  const bool left = p < n && x >= pc.min_disparity + D - 1;
  if (left) {
    uint key = 0xFFFFFFFFu;
    for (int d = part; d < D; d += kParts) key = min(key, (sum_at(p, d) << 9) | uint(d));
    atomicMin(left_best[p], key);
  }
  barrier();
  const uint best = left_best[p] >> 9;
  const int bd = int(left_best[p] & 511u);
  if (left) {
    bool unique = true;
    for (int d = part; d < D; d += kParts) {
      if (abs(d - bd) > 1 && sum_at(p, d) * uint(100 - pc.uniqueness) < best * 100u) unique = false;
    }
    if (!unique) atomicOr(ambiguous[p], 1u);
  }
  barrier();
  if (p < n && part == 0) {
    int out_l = -1;
    if (left && ambiguous[p] == 0u) {
      out_l = (pc.min_disparity + bd) * 64;
      if (bd > 0 && bd < D - 1) {
        const int a = int(sum_at(p, bd - 1)), b = int(sum_at(p, bd + 1));
        const int den = max(a + b - 2 * int(best), 1);
        const int num = (a - b) * 64 + den;
        out_l += num >= 0 ? num / (2 * den) : -((-num) / (2 * den));
      }
    }
    disp_l[y * W + x] = out_l;
  }

  for (int i = t; i < n * D; i += 128) {
    const int q = i / D, d = i - q * D;
    atomicMin(right_best[q + (D - 1) - d], (sum_at(q, d) << 9) | uint(d));
  }
  barrier();
  for (int i = t; i < span; i += 128) {
    const int xr = base + i;
    if (xr >= 0 && xr < W && right_best[i] != 0xFFFFFFFFu) atomicMin(right_key[y * W + xr], right_best[i]);
  }
}
