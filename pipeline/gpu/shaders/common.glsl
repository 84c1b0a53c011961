// Shared by the SGM shaders: the arithmetic here is mirrored exactly in sgm_reference.cpp.
// Images are 8-bit grey packed four pixels to a 32-bit word (little end first), rows padded to whole words.
uint pixel_at(uint word, int x) { return (word >> (uint(x & 3) * 8u)) & 0xFFu; }

// The disparity the host downloads (gpu::DisparityView), 16 bits a pixel: d = base + value / scale px,
// value (d - base) * scale rounded half to even, 0xFFFF invalid (as is anything outside 0..65534, which
// the host's choice of base and scale keeps out: vulkan/output.cpp).
const uint kInvalidDisparity = 0xFFFFu;
uint encode_disparity(float d, int base, int scale) {
  if (isnan(d) || isinf(d)) return kInvalidDisparity;
  const float v = roundEven((d - float(base)) * float(scale));
  return v >= 0.0 && v <= 65534.0 ? uint(v) : kInvalidDisparity;
}
