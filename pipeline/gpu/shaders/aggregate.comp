#version 450
// All SGM path directions in one dispatch: workgroup (line, direction) walks one line of the image in
// direction kDirections[direction] (as sgm_reference.cpp). Its 32 invocations own the disparities in
// fours, d = 128 j + 4 t + e (j < kGroups, e < 4): they read the matching costs C of their four disparities
// as one word of cost.comp's volume, and store the four path costs L as one word of four bytes in that
// direction's own volume, path_cost[direction][y][x][word]; winner-takes-all (wta.comp) adds the
// directions. No atomics and no zeroing: every word is written by exactly one invocation.
//   L(p, d) = C(p, d) + min(L(p-r, d), L(p-r, d-1) + P1, L(p-r, d+1) + P1, min_k L(p-r, k) + P2) - min_k L(p-r, k)
// L <= 64 + P2, and the host keeps P2 <= 191 (kMaxP2), so L fits a byte.
// The walk is latency-bound, so no global load waits inside a step: the costs of the next kRing steps are
// loaded while the current kRing steps run (the step loop is unrolled kRing times, so the ring lives in
// registers). Works for any subgroup size: the minimum over disparities is a subgroup minimum, then one
// value per subgroup through shared memory.
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
layout(local_size_x = 32) in;
// Words of four disparities per invocation: num_disparities / 128 rounded up, set when the pipeline is made.
layout(constant_id = 0) const int kGroups = 4;
layout(std430, binding = 0) readonly buffer Cost { uint cost[]; };  // cost.comp's, [y][x][word]
// One buffer per direction (each within the device's storage-buffer range), [y][x][word], 4 bytes a word;
// words per pixel: num_disparities / 4 rounded up.
layout(std430, binding = 1) writeonly buffer PathCost { uint w[]; } path_cost[8];
layout(push_constant) uniform Params { int width, height, num_disparities, p1, p2, words; } pc;

const uint kBig = 0xFFFFu;  // beyond any L; the sentinels at d = -1 and d = num_disparities
const int kRing = 8;
const ivec2 kDirections[8] = ivec2[8](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1), ivec2(1, 1), ivec2(-1, 1),
                                      ivec2(1, -1), ivec2(-1, -1));
shared uint path[2][128 * kGroups + 2];  // L of the previous and current pixel, index d + 1
shared uint subgroup_min[2][32];

void main() {
  const int W = pc.width, H = pc.height, D = pc.num_disparities;
  const uint dir = gl_WorkGroupID.y;
  const int dx = kDirections[dir].x, dy = kDirections[dir].y;
  const int line = int(gl_WorkGroupID.x);
  if (line >= (dy == 0 ? H : dx == 0 ? W : W + H - 1)) return;  // the whole workgroup: no barrier skipped
  // Start of the line: the pixels whose predecessor (x - dx, y - dy) lies outside the image.
  int x0, y0;
  if (dy == 0) {
    x0 = dx > 0 ? 0 : W - 1; y0 = line;
  } else if (line < W) {
    x0 = line; y0 = dy > 0 ? 0 : H - 1;
  } else {  // diagonals starting on the left or right column, below (above) the first row
    x0 = dx > 0 ? 0 : W - 1;
    y0 = dy > 0 ? 1 + (line - W) : H - 2 - (line - W);
  }
  // Steps until the line leaves the image.
  const int along_x = dx == 0 ? 1 << 30 : dx > 0 ? W - x0 : x0 + 1;
  const int along_y = dy == 0 ? 1 << 30 : dy > 0 ? H - y0 : y0 + 1;
  const int steps = min(along_x, along_y);
  const int t = int(gl_LocalInvocationID.x);
  for (int i = t; i < 128 * kGroups + 2; i += 32) { path[0][i] = kBig; path[1][i] = kBig; }

  uint ring[kRing][kGroups], next[kRing][kGroups];
  for (int s = 0; s < kRing; ++s)
    for (int j = 0; j < kGroups; ++j) {
      const int word = 32 * j + t, x = x0 + s * dx, y = y0 + s * dy;
      ring[s][j] = s < steps && word < pc.words ? cost[(y * W + x) * pc.words + word] : 0u;
    }
  barrier();

  uint prev_min = 0u;
  for (int block = 0; block * kRing < steps; ++block) {
    for (int s = 0; s < kRing; ++s)  // the next block's costs, in flight during this block
      for (int j = 0; j < kGroups; ++j) {
        const int step = (block + 1) * kRing + s, word = 32 * j + t, x = x0 + step * dx, y = y0 + step * dy;
        next[s][j] = step < steps && word < pc.words ? cost[(y * W + x) * pc.words + word] : 0u;
      }
    for (int s = 0; s < kRing; ++s) {
      const int step = block * kRing + s;
      if (step >= steps) break;  // uniform: the barrier below is skipped by the whole workgroup
      const int x = x0 + step * dx, y = y0 + step * dy;
      const int cur = step & 1, prv = cur ^ 1;
      uint local_min = kBig;
      for (int j = 0; j < kGroups; ++j) {
        const int word = 32 * j + t;
        if (word >= pc.words) break;
        uint packed = 0u;
        for (int e = 0; e < 4; ++e) {
          const int d = 4 * word + e;
          if (d >= D) break;
          const uint c = (ring[s][j] >> uint(8 * e)) & 0xFFu;
          uint l = c;
          if (step > 0) {
            const uint near = min(path[prv][d], path[prv][d + 2]) + uint(pc.p1);
            l = c + min(min(path[prv][d + 1], near), prev_min + uint(pc.p2)) - prev_min;
          }
          path[cur][d + 1] = l;
          local_min = min(local_min, l);
          packed |= l << uint(8 * e);
        }
        path_cost[dir].w[(y * W + x) * pc.words + word] = packed;
      }
      const uint m = subgroupMin(local_min);
      if (subgroupElect()) subgroup_min[cur][gl_SubgroupID] = m;
      barrier();  // path[cur] and subgroup_min[cur] complete; the next step writes the other halves
      prev_min = kBig;
      for (uint g = 0u; g < gl_NumSubgroups; ++g) prev_min = min(prev_min, subgroup_min[cur][g]);
    }
    ring = next;
  }
}
