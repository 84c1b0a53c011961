// Shared by the SGM shaders: the arithmetic here is mirrored exactly in sgm_reference.cpp.
// Images are 8-bit grey packed four pixels to a 32-bit word (little end first), rows padded to whole words.
uint pixel_at(uint word, int x) { return (word >> (uint(x & 3) * 8u)) & 0xFFu; }
