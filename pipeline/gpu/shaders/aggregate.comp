#version 450
// All SGM path directions in one dispatch: workgroup (line, direction) walks one line of the image in
// direction kDirections[direction] (as sgm_reference.cpp). Its kThreads invocations own consecutive
// blocks of kWords words of four disparities: invocation t has d = 4 (kWords t + k) + e, k < kWords,
// e < 4. They read the matching costs C of a word from cost.comp's volume and store the four path costs L
// as one word of four bytes in that direction's own volume, path_cost[direction][y][x][word];
// winner-takes-all (wta.comp) adds the directions. No atomics and no zeroing: every word is written once.
//   L(p, d) = C(p, d) + min(L(p-r, d), L(p-r, d-1) + P1, L(p-r, d+1) + P1, min_k L(p-r, k) + P2) - min_k L(p-r, k)
// L <= 64 + P2, and the host keeps P2 <= 191 (kMaxP2), so L fits a byte.
//
// Each step depends on the last, so the walk is bound by the latency of a step. An invocation keeps its
// own L in registers; only the L at the edges of its block and the minimum cross invocations. When the
// workgroup is one subgroup (kThreads is the device's subgroup size) they cross by shuffles and a
// subgroup minimum: no barrier, no shared memory. Where the device runs it as several subgroups (a
// driver free to pick a smaller size), they cross through shared memory with one barrier a step: the
// same arithmetic, slower. The costs of the next kRing steps are loaded while the current kRing steps run
// (the loops over the ring and an invocation's disparities are unrolled, so both live in registers).
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_shuffle_relative : require
#extension GL_EXT_control_flow_attributes : require
// Set when the pipeline is made: the subgroup size the device reports, and
// kWords = num_disparities / 4 / kThreads rounded up, for the most disparities the matcher takes.
layout(local_size_x_id = 0) in;
layout(constant_id = 0) const int kThreads = 32;
layout(constant_id = 1) const int kWords = 1;
layout(std430, binding = 0) readonly buffer Cost { uint cost[]; };  // cost.comp's, [y][x][word]
// One buffer per direction (each within the device's storage-buffer range), [y][x][word], 4 bytes a word;
// words per pixel: num_disparities / 16 rounded up, times 4 (the bytes past num_disparities are 0xFF).
layout(std430, binding = 1) writeonly buffer PathCost { uint w[]; } path_cost[8];
// segment, run_in: SgmConfig::segment (0: off) and segment_run_in; workgroup z is the segment of a row.
layout(push_constant) uniform Params { int width, height, num_disparities, p1, p2, words, segment, run_in; } pc;

const uint kBig = 0xFFFFu;  // beyond any L: the disparities outside the band
const int kRing = 8;
const int kOwn = 4 * kWords;  // disparities per invocation
const ivec2 kDirections[8] = ivec2[8](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1), ivec2(1, 1), ivec2(-1, 1),
                                      ivec2(1, -1), ivec2(-1, -1));
// The shared-memory exchange, by step parity: each invocation's first and last L, each subgroup's minimum.
shared uint edge_first[2][kThreads], edge_last[2][kThreads], subgroup_min[2][kThreads];

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
  // Rows in segments: segment z keeps walk steps [z S, (z + 1) S), walked from max(0, z S - run_in).
  const int seg = int(gl_WorkGroupID.z);
  int keep_from = 0, seg_end = 1 << 30;
  if (dy == 0 && pc.segment > 0) {
    if (seg * pc.segment >= W) return;
    const int begin = max(0, seg * pc.segment - pc.run_in);
    seg_end = min((seg + 1) * pc.segment, W) - begin;
    keep_from = seg * pc.segment - begin;
    x0 += begin * dx;
  } else if (seg > 0) {
    return;  // other directions, and unsegmented rows, have one segment
  }
  const int along_x = dx == 0 ? 1 << 30 : dx > 0 ? W - x0 : x0 + 1;
  const int along_y = dy == 0 ? 1 << 30 : dy > 0 ? H - y0 : y0 + 1;
  const int steps = min(min(along_x, along_y), seg_end);  // until the line leaves the image or its segment
  const int t = int(gl_LocalInvocationID.x);
  const int first_word = kWords * t;
  const bool one_subgroup = gl_NumSubgroups == 1u;

  uint ring[kRing][kWords], next[kRing][kWords];
  [[unroll]] for (int s = 0; s < kRing; ++s)
    [[unroll]] for (int k = 0; k < kWords; ++k) {
      const int word = first_word + k, x = x0 + s * dx, y = y0 + s * dy;
      ring[s][k] = s < steps && word < pc.words ? cost[(y * W + x) * pc.words + word] : 0u;
    }

  uint prev[kOwn];
  [[unroll]] for (int i = 0; i < kOwn; ++i) prev[i] = kBig;
  uint below = kBig, above = kBig;  // L(p-r) at this block's first d - 1 and last d + 1
  uint prev_min = 0u;
  for (int block = 0; block * kRing < steps; ++block) {
    [[unroll]] for (int s = 0; s < kRing; ++s)  // the next block's costs, in flight during this block
      [[unroll]] for (int k = 0; k < kWords; ++k) {
        const int step = (block + 1) * kRing + s, word = first_word + k, x = x0 + step * dx, y = y0 + step * dy;
        next[s][k] = step < steps && word < pc.words ? cost[(y * W + x) * pc.words + word] : 0u;
      }
    [[unroll]] for (int s = 0; s < kRing; ++s) {
      const int step = block * kRing + s;
      if (step >= steps) break;  // uniform: the whole workgroup leaves together
      const int x = x0 + step * dx, y = y0 + step * dy;
      uint cur[kOwn];
      uint local_min = kBig;
      [[unroll]] for (int i = 0; i < kOwn; ++i) {
        const int d = 4 * first_word + i;
        uint l = kBig;
        if (d < D) {
          const uint c = (ring[s][i / 4] >> uint(8 * (i % 4))) & 0xFFu;
          l = c;
          if (step > 0) {
            const uint lo = i == 0 ? below : prev[i == 0 ? 0 : i - 1];
            const uint hi = i == kOwn - 1 ? above : prev[i == kOwn - 1 ? i : i + 1];
            l = c + min(min(prev[i], min(lo, hi) + uint(pc.p1)), prev_min + uint(pc.p2)) - prev_min;
          }
          local_min = min(local_min, l);
        }
        cur[i] = l;
      }
      [[unroll]] for (int k = 0; k < kWords; ++k) {
        const int word = first_word + k;
        if (word < pc.words && step >= keep_from)
          path_cost[dir].w[(y * W + x) * pc.words + word] =
              (cur[4 * k] & 0xFFu) | ((cur[4 * k + 1] & 0xFFu) << 8) | ((cur[4 * k + 2] & 0xFFu) << 16) |
              ((cur[4 * k + 3] & 0xFFu) << 24);
      }
      if (one_subgroup) {
        below = subgroupShuffleUp(cur[kOwn - 1], 1u);
        above = subgroupShuffleDown(cur[0], 1u);
        if (t == 0) below = kBig;
        if (t == kThreads - 1) above = kBig;
        prev_min = subgroupMin(local_min);
      } else {
        const int par = step & 1;  // two copies: the next step's writes need no second barrier
        edge_first[par][t] = cur[0];
        edge_last[par][t] = cur[kOwn - 1];
        const uint m = subgroupMin(local_min);
        if (subgroupElect()) subgroup_min[par][gl_SubgroupID] = m;
        barrier();
        below = t > 0 ? edge_last[par][t - 1] : kBig;
        above = t < kThreads - 1 ? edge_first[par][t + 1] : kBig;
        prev_min = kBig;
        for (uint g = 0u; g < gl_NumSubgroups; ++g) prev_min = min(prev_min, subgroup_min[par][g]);
      }
      [[unroll]] for (int i = 0; i < kOwn; ++i) prev[i] = cur[i];
    }
    [[unroll]] for (int r = 0; r < kRing; ++r)
      [[unroll]] for (int k = 0; k < kWords; ++k) ring[r][k] = next[r][k];
  }
}
