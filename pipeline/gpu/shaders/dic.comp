#version 450
// Sub-pixel refinement by digital image correlation: inverse-compositional Gauss-Newton on the
// zero-normalised SSD over the first-order warp x_right = x + c + a xi + b eta (start a = 1, b = 0,
// c = -d0), the right image sampled by its cubic B-spline along rows. The maths and the rejections are
// pipeline/dic_refine.hpp's (DicConfig), in float, as dic_reference.cpp; no warm start from the
// neighbour (windows are independent here). One subgroup per window (or a workgroup of kGroups
// subgroups, below): its invocations take the window's pixels in turn and every sum is a subgroup sum,
// so all invocations hold the same totals and take the same branches; the sums' order differs from the
// reference's, which agrees to float rounding. Works for any subgroup size: each subgroup walks the
// columns with the stride of the whole dispatch. The output is
// the 16-bit fixed-point disparity the host downloads (common.glsl), every pixel written once: refined, or
// invalid where no window refined it (no fill before).
// Two modes (specialization constant 0):
// - per pixel: one window around each pixel of the grid (x % step == 0, y % row_step == 0, rows
//   [row_begin, row_end)) with a valid disparity d0; workgroup (x, row), every row of the image.
// - column windows (dic.hpp DicKernelConfig::column_windows, the geometry of pipeline/dic_refine.cpp): one
//   window per column and row block, as tall as the block and centred on its middle row yc, started
//   from the median of the column's valid disparities in the block; every row y of the block gets
//   -(c + b (y - yc)); workgroup (x, block); the first and last blocks' workgroups also write the rows
//   above and below the blocks (with no block, workgroup row 0 writes every row).
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_EXT_shader_16bit_storage : require
layout(local_size_x_id = 2) in;
layout(constant_id = 0) const bool kColumnWindows = false;
// The subgroups that share a window: 1, its own subgroup (several windows a workgroup); more (column
// windows), every subgroup of the workgroup, one window a workgroup: each sums its pixels, and the
// subgroups' sums meet in shared memory behind a barrier, added in the same order by every invocation so
// that all hold the same totals and take the same branches. For tall windows on few columns (a strip's
// whole-height windows), which one subgroup walks pixel after pixel. kWorkgroup: the workgroup size.
layout(constant_id = 1) const int kGroups = 1;
layout(constant_id = 2) const int kWorkgroup = 64;
layout(std430, binding = 0) readonly buffer Left { uint left_px[]; };
layout(std430, binding = 1) readonly buffer CoefL { float coef_l[]; };
layout(std430, binding = 2) readonly buffer CoefR { float coef_r[]; };
layout(std430, binding = 3) readonly buffer Initial { float initial[]; };
layout(std430, binding = 4) writeonly buffer Refined { uint16_t refined[]; };
layout(push_constant) uniform Params {
  // hh: the window's half height (per pixel), or the half height the convergence test weighs the row
  // slope with (column windows: ColumnBlocks::half_height). first_row: the first grid row (per pixel),
  // or row_begin (column windows); last_row: the grid's rows end before it (per pixel). rows, blocks:
  // column windows' rows from row_begin and row blocks. base, scale: the output's fixed point.
  int width, height, words_per_row, h, hh, max_iterations, step, row_step, first_row, last_row, first_order;
  float tolerance, max_shift, max_gradient, min_gradient, min_zncc, max_sigma;
  int rows, blocks, base, scale;
} pc;
#include "common.glsl"

const int kCache = 8;  // window pixels an invocation keeps in registers

// The window's partial sums, two copies used in turn (as wta.comp's exchange); subgroups of at least 4
// invocations (the host keeps kGroups at 1 on narrower ones).
const int kMaxSums = 14;
shared float partial[2][kGroups > 1 ? kWorkgroup / 4 : 1][kMaxSums];
int turn = 0;

// The invocations that share a window, and this one's index among them.
int window_lanes() { return kGroups == 1 ? int(gl_SubgroupSize) : int(gl_WorkGroupSize.x); }
int window_lane() { return kGroups == 1 ? int(gl_SubgroupInvocationID) : int(gl_LocalInvocationID.x); }

// v[0, n) summed over the window's invocations; every invocation gets the same totals.
void window_sums(inout float v[kMaxSums], int n) {
  for (int i = 0; i < n; ++i) v[i] = subgroupAdd(v[i]);
  if (kGroups == 1) return;
  if (subgroupElect())
    for (int i = 0; i < n; ++i) partial[turn][gl_SubgroupID][i] = v[i];
  barrier();
  for (int i = 0; i < n; ++i) {
    float total = 0.0;
    for (uint g = 0u; g < gl_NumSubgroups; ++g) total += partial[turn][g][i];
    v[i] = total;
  }
  turn ^= 1;
}

float window_min(float v) {
  v = subgroupMin(v);
  if (kGroups == 1) return v;
  if (subgroupElect()) partial[turn][gl_SubgroupID][0] = v;
  barrier();
  for (uint g = 0u; g < gl_NumSubgroups; ++g) v = min(v, partial[turn][g][0]);
  turn ^= 1;
  return v;
}

int mirror(int k) { return k < 0 ? -k : k > pc.width - 1 ? 2 * (pc.width - 1) - k : k; }

// The right spline at position X of row r, minus 128 (power form on [k, k+1), as the CPU tables).
float sample_right(int r, float X) {
  const int k = min(int(floor(X)), pc.width - 1);
  precise const float t = X - float(k);
  const int row = r * pc.width;
  const float cm = coef_r[row + mirror(k - 1)], c0 = coef_r[row + k], c1 = coef_r[row + mirror(k + 1)],
              c2 = coef_r[row + mirror(k + 2)];
  precise const float p0 = (cm + (4.0 * c0 + c1)) * (1.0 / 6.0) - 128.0;
  precise const float p1 = 0.5 * (c1 - cm);
  precise const float p2 = 0.5 * (cm - 2.0 * c0 + c1);
  precise const float p3 = (3.0 * (c0 - c1) + (c2 - cm)) * (1.0 / 6.0);
  precise const float g = p0 + t * (p1 + t * (p2 + t * p3));
  return g;
}

float left_grey(int cx, int r) { return float(pixel_at(left_px[r * pc.words_per_row + (cx >> 2)], cx)) - 128.0; }
float left_dx(int cx, int r) {
  precise const float fx = 0.5 * (coef_l[r * pc.width + mirror(cx + 1)] - coef_l[r * pc.width + mirror(cx - 1)]);
  return fx;
}

// One window, columns [x0, x1] and rows [y0, y1] around (x, y), from d0: true when it converged and
// passed every test, with the warp's b and c. Uniform in the subgroup.
bool solve(int x, int y, int x0, int x1, int y0, int y1, float d0, out float b_out, out float c_out) {
  const int wx = x1 - x0 + 1, npx = wx * (y1 - y0 + 1);
  const float n = float(npx);
  const int lane = window_lane(), lanes = window_lanes();

  // Reference side: f = left - 128, fx its spline's derivative, sd = fx (1, xi, eta).
  precise float f_sum = 0.0, ff = 0.0;
  precise float hm[6] = float[6](0.0, 0.0, 0.0, 0.0, 0.0, 0.0);  // H00 H01 H02 H11 H12 H22
  precise float sd_sum[3] = float[3](0.0, 0.0, 0.0), sd_fs[3] = float[3](0.0, 0.0, 0.0);
  // An invocation's first kCache pixels keep their position, grey and gradient in registers for the
  // iterations (11 x 11 windows need 4 a lane at subgroup size 32); any further pixels are read again.
  int cache_r[kCache], cache_x[kCache];
  float cache_f[kCache], cache_fx[kCache];
  for (int k = lane; k < npx; k += lanes) {
    const int r = y0 + k / wx, cx = x0 + k % wx;
    const float eta = float(r - y), xi = float(cx - x);
    const float f = left_grey(cx, r);
    precise const float fx = left_dx(cx, r);
    const int j = (k - lane) / lanes;
    [[unroll]] for (int q = 0; q < kCache; ++q)
      if (q == j) { cache_r[q] = r; cache_x[q] = cx; cache_f[q] = f; cache_fx[q] = fx; }
    f_sum += f;
    ff += f * f;
    precise const float w = fx * fx;
    hm[0] += w; hm[1] += w * xi; hm[2] += w * eta; hm[3] += w * xi * xi; hm[4] += w * xi * eta; hm[5] += w * eta * eta;
    sd_sum[0] += fx; sd_sum[1] += fx * xi; sd_sum[2] += fx * eta;
    sd_fs[0] += fx * f; sd_fs[1] += fx * f * xi; sd_fs[2] += fx * f * eta;
  }
  {
    float v[kMaxSums] = float[kMaxSums](f_sum, ff, hm[0], hm[1], hm[2], hm[3], hm[4], hm[5], sd_sum[0], sd_sum[1],
                                        sd_sum[2], sd_fs[0], sd_fs[1], sd_fs[2]);
    window_sums(v, 14);
    f_sum = v[0];
    ff = v[1];
    for (int k = 0; k < 6; ++k) hm[k] = v[2 + k];
    for (int k = 0; k < 3; ++k) { sd_sum[k] = v[8 + k]; sd_fs[k] = v[11 + k]; }
  }
  precise const float f_mean = f_sum / n;
  precise const float f2 = ff - f_sum * f_mean;
  if (hm[0] < pc.min_gradient * pc.min_gradient * n || !(f2 > 0.0)) return false;
  const float norm = sqrt(f2);
  precise float sd_f[3];
  for (int k = 0; k < 3; ++k) sd_f[k] = sd_fs[k] - f_mean * sd_sum[k];
  precise float inv[6];  // symmetric inverse, same order as hm
  if (pc.first_order != 0) {
    precise const float c00 = hm[3] * hm[5] - hm[4] * hm[4];
    precise const float c01 = hm[4] * hm[2] - hm[1] * hm[5];
    precise const float c02 = hm[1] * hm[4] - hm[3] * hm[2];
    precise const float det = hm[0] * c00 + hm[1] * c01 + hm[2] * c02;
    if (!(det > 1e-12 * hm[0] * hm[3] * hm[5])) return false;
    const float s = 1.0 / det;
    inv[0] = c00 * s; inv[1] = c01 * s; inv[2] = c02 * s;
    inv[3] = (hm[0] * hm[5] - hm[2] * hm[2]) * s;
    inv[4] = (hm[2] * hm[1] - hm[0] * hm[4]) * s;
    inv[5] = (hm[0] * hm[3] - hm[1] * hm[1]) * s;
  } else {
    inv[0] = 1.0 / hm[0]; inv[1] = 0.0; inv[2] = 0.0; inv[3] = 0.0; inv[4] = 0.0; inv[5] = 0.0;
  }

  precise float a = 1.0, b = 0.0, c = -d0;
  const float last = float(pc.width - 1);
  for (int it = 1; it <= pc.max_iterations; ++it) {
    // a > 0 and b bounded: the extreme samples are at the window's corners.
    for (int corner = 0; corner < 4; ++corner) {
      precise const float X = float(x) + c + a * float((corner & 1) == 0 ? x0 - x : x1 - x) +
                              b * float((corner & 2) == 0 ? y0 - y : y1 - y);
      if (!(X >= 0.0 && X <= last)) return false;
    }
    precise float g_sum = 0.0, gg = 0.0, fg = 0.0;
    precise float sd_g[3] = float[3](0.0, 0.0, 0.0);
    [[unroll]] for (int q = 0; q < kCache; ++q) {
      if (lane + q * lanes < npx) {
        const int r = cache_r[q], cx = cache_x[q];
        const float eta = float(r - y), xi = float(cx - x);
        precise const float X = float(x) + c + a * xi + b * eta;
        const float g = sample_right(r, X);
        const float f = cache_f[q];
        precise const float fx = cache_fx[q];
        g_sum += g;
        gg += g * g;
        fg += f * g;
        sd_g[0] += fx * g; sd_g[1] += fx * g * xi; sd_g[2] += fx * g * eta;
      }
    }
    for (int k = lane + kCache * lanes; k < npx; k += lanes) {
      const int r = y0 + k / wx, cx = x0 + k % wx;
      const float eta = float(r - y), xi = float(cx - x);
      precise const float X = float(x) + c + a * xi + b * eta;
      const float g = sample_right(r, X);
      const float f = left_grey(cx, r);
      precise const float fx = left_dx(cx, r);
      g_sum += g;
      gg += g * g;
      fg += f * g;
      sd_g[0] += fx * g; sd_g[1] += fx * g * xi; sd_g[2] += fx * g * eta;
    }
    {
      float v[kMaxSums];
      v[0] = g_sum; v[1] = gg; v[2] = fg; v[3] = sd_g[0]; v[4] = sd_g[1]; v[5] = sd_g[2];
      window_sums(v, 6);
      g_sum = v[0]; gg = v[1]; fg = v[2]; sd_g[0] = v[3]; sd_g[1] = v[4]; sd_g[2] = v[5];
    }
    precise const float g_mean = g_sum / n;
    precise const float g2 = gg - g_sum * g_mean;
    if (!(g2 > 1e-6)) return false;
    precise const float fgc = fg - f_sum * g_mean;
    const float inv_g_norm = 1.0 / sqrt(g2);
    precise const float kk = norm * inv_g_norm;
    precise float bv[3];
    for (int k = 0; k < 3; ++k) bv[k] = sd_f[k] - kk * (sd_g[k] - g_mean * sd_sum[k]);
    precise const float zncc = fgc * inv_g_norm / norm;
    precise const float du = -(inv[0] * bv[0] + inv[1] * bv[1] + inv[2] * bv[2]);
    precise const float dux = -(inv[1] * bv[0] + inv[3] * bv[1] + inv[4] * bv[2]);
    precise const float duy = -(inv[2] * bv[0] + inv[4] * bv[1] + inv[5] * bv[2]);
    // W <- W o W(dp)^-1 ; W(dp)^-1: xi' = (xi - duy eta - du) / (1 + dux).
    const float ai = 1.0 / (1.0 + dux);
    precise const float na = a * ai, nb = b - a * duy * ai, nc = c - a * du * ai;
    a = na; b = nb; c = nc;
    if (isnan(c) || isinf(c) || abs(a - 1.0) > pc.max_gradient || abs(b) > pc.max_gradient ||
        abs(-c - d0) > pc.max_shift)
      return false;
    precise const float corner2 = du * du + float(pc.h * pc.h) * dux * dux + float(pc.hh * pc.hh) * duy * duy;
    if (pc.tolerance > 0.0 && corner2 < pc.tolerance * pc.tolerance) {
      if (pc.max_sigma > 0.0) {
        const float unknowns = pc.first_order != 0 ? 3.0 : 1.0;
        if (n <= unknowns) return false;
        const float r2 = max(0.0, 2.0 * f2 * (1.0 - zncc));
        const float variance = r2 / (n - unknowns) * inv[0];
        if (!(variance <= pc.max_sigma * pc.max_sigma)) return false;
      }
      b_out = b;
      c_out = c;
      return zncc >= pc.min_zncc;
    }
  }
  return false;
}

void store(int x, int y, uint value) { refined[y * pc.width + x] = uint16_t(value); }

// The window around (x, y) of the grid; its refined disparity or invalid.
void refine_pixel(int x, int y) {
  const float d0 = initial[y * pc.width + x];
  uint out_value = kInvalidDisparity;
  if (!isnan(d0)) {
    const int x0 = max(0, x - pc.h), x1 = min(pc.width - 1, x + pc.h);
    const int y0 = max(0, y - pc.hh), y1 = min(pc.height - 1, y + pc.hh);
    float b, c;
    if (solve(x, y, x0, x1, y0, y1, d0, b, c)) out_value = encode_disparity(-c, pc.base, pc.scale);
  }
  if (subgroupElect()) store(x, y, out_value);
}

// Rows [y0, y1) invalid, by every invocation of the workgroups of one workgroup row, coalesced.
void invalidate_rows(int y0, int y1) {
  const int stride = int(gl_NumWorkGroups.x * gl_WorkGroupSize.x);
  for (int y = y0; y < y1; ++y)
    for (int x = int(gl_GlobalInvocationID.x); x < pc.width; x += stride) store(x, y, kInvalidDisparity);
}

bool valid_disparity(float d) { return !isnan(d) && !isinf(d); }

// The start of the column window at x over rows [y0, y1]: the median of the column's valid initial
// disparities there, the element nth_element puts at n / 2 (dic_refine.cpp): the value v with
// #(values < v) <= n / 2 < #(values <= v), found by counting (a block is tens of rows). False when fewer
// than a quarter of the rows are valid. Uniform in the subgroup.
bool column_start(int x, int y0, int y1, out float start) {
  const int lane = window_lane(), lanes = window_lanes();
  int count = 0;
  for (int r = y0 + lane; r <= y1; r += lanes) count += valid_disparity(initial[r * pc.width + x]) ? 1 : 0;
  float counts[kMaxSums];
  counts[0] = float(count);  // exact: a block's rows
  window_sums(counts, 1);
  const int n = int(counts[0]);
  if (n == 0 || 4 * n < y1 - y0 + 1) return false;
  const int k = n / 2;
  float found = uintBitsToFloat(0x7F800000u);  // +inf: no candidate on this invocation
  for (int r = y0 + lane; r <= y1; r += lanes) {
    const float v = initial[r * pc.width + x];
    if (!valid_disparity(v)) continue;
    int less = 0, less_equal = 0;
    for (int s = y0; s <= y1; ++s) {
      const float u = initial[s * pc.width + x];
      if (!valid_disparity(u)) continue;
      less += u < v ? 1 : 0;
      less_equal += u <= v ? 1 : 0;
    }
    if (less <= k && k < less_equal) found = min(found, v);  // every such v is the same value
  }
  start = window_min(found);
  return true;
}

int block_begin(int b) { return pc.first_row + pc.rows * b / pc.blocks; }

// The column window at x in `block`: every row of the block refined, or all invalid.
void refine_column(int x, int block) {
  const int y0 = block_begin(block), y1 = block_begin(block + 1) - 1, yc = (y0 + y1) / 2;
  float d0, b = 0.0, c = 0.0;
  bool ok = column_start(x, y0, y1, d0);
  if (ok) {
    const int x0 = max(0, x - pc.h), x1 = min(pc.width - 1, x + pc.h);
    ok = solve(x, yc, x0, x1, y0, y1, d0, b, c);
  }
  for (int r = y0 + window_lane(); r <= y1; r += window_lanes()) {
    precise const float d = -(c + b * float(r - yc));
    store(x, r, ok ? encode_disparity(d, pc.base, pc.scale) : kInvalidDisparity);
  }
}

void main() {
  // Windows: one a subgroup, or one a workgroup (kGroups > 1).
  const int stride = int(gl_NumWorkGroups.x) * (kGroups == 1 ? int(gl_NumSubgroups) : 1);
  const int first = int(gl_WorkGroupID.x) * (kGroups == 1 ? int(gl_NumSubgroups) : 1) +
                    (kGroups == 1 ? int(gl_SubgroupID) : 0);
  const int lane = int(gl_SubgroupInvocationID);
  if (kColumnWindows) {
    const int block = int(gl_WorkGroupID.y), last = pc.first_row + pc.rows;
    if (pc.blocks == 0 || pc.width < 4) {  // nothing refined: workgroup row 0 writes every row
      if (block == 0) invalidate_rows(0, pc.height);
      return;
    }
    if (block == 0) invalidate_rows(0, pc.first_row);
    if (block == pc.blocks - 1) invalidate_rows(last, pc.height);
    for (int x = first; x < pc.width; x += stride) refine_column(x, block);
  } else {
    const int y = int(gl_WorkGroupID.y);
    const bool grid_row = pc.width >= 4 && y >= pc.first_row && y < pc.last_row && (y - pc.first_row) % pc.row_step == 0;
    if (!grid_row) {
      invalidate_rows(y, y + 1);
      return;
    }
    // Each subgroup a run of columns: windows where x % step == 0, invalid between them.
    for (int x = first; x < pc.width; x += stride) {
      if (x % pc.step == 0) refine_pixel(x, y);
      else if (lane == 0) store(x, y, kInvalidDisparity);
    }
  }
}
