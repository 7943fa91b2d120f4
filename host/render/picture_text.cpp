// A 3 x 5 pixel font (digits, letters drawn as capitals, a few signs) scaled up, so that a
// figure names its panels and axes without a font library.
#include "potmap/render/picture.hpp"

#include <cctype>
#include <cstdint>

namespace potmap {

namespace {

// Each glyph is five rows of three bits, top row first, the leftmost pixel the highest bit.
std::uint16_t glyph(char c) {
  static const char* const letters[26] = {
      "010101111101101", "110101110101110", "011100100100011", "110101101101110", "111100110100111",
      "111100110100100", "011100101101011", "101101111101101", "111010010010111", "001001001101010",
      "101101110101101", "100100100100111", "101111111101101", "110101101101101", "010101101101010",
      "110101110100100", "010101101110011", "110101110101101", "011100010001110", "111010010010010",
      "101101101101111", "101101101101010", "101101111111101", "101101010101101", "101101010010010",
      "111001010100111"};
  static const char* const digits[10] = {"111101101101111", "010110010010111", "111001111100111",
                                         "111001111001111", "101101111001001", "111100111001111",
                                         "111100111101111", "111001001001001", "111101111101111",
                                         "111101111001111"};
  const char* bits = nullptr;
  const unsigned char u = static_cast<unsigned char>(c);
  if (std::isalpha(u)) bits = letters[std::tolower(u) - 'a'];
  if (std::isdigit(u)) bits = digits[u - '0'];
  switch (c) {
    case '.':
      bits = "000000000000010";
      break;
    case '_':
      bits = "000000000000111";
      break;
    case '=':
      bits = "000111000111000";
      break;
    case '/':
      bits = "001001010100100";
      break;
    case ',':
      bits = "000000000010100";
      break;
    case '(':
      bits = "010100100100010";
      break;
    case ')':
      bits = "010001001001010";
      break;
    case '-':
      bits = "000000111000000";
      break;
    case '*':
      bits = "000101010101000";
      break;
    case ':':
      bits = "000010000010000";
      break;
    case '^':
      bits = "010101000000000";
      break;
    case '+':
      bits = "000010111010000";
      break;
    case '\'':
      bits = "010010000000000";
      break;
    default:
      break;
  }
  std::uint16_t g = 0;
  for (int i = 0; bits && i < 15; ++i) g = static_cast<std::uint16_t>((g << 1) | (bits[i] == '1'));
  return g;
}

}  // namespace

void draw_text(Picture& pic, long x, long y, const std::string& text, Rgb colour, int scale) {
  for (char c : text) {
    const std::uint16_t g = glyph(c);
    for (int row = 0; row < 5; ++row)
      for (int col = 0; col < 3; ++col) {
        if (!((g >> (14 - (row * 3 + col))) & 1)) continue;
        for (int dy = 0; dy < scale; ++dy)
          for (int dx = 0; dx < scale; ++dx) {
            const long px = x + col * scale + dx, py = y + row * scale + dy;
            if (px < 0 || py < 0 || px >= long(pic.width) || py >= long(pic.height)) continue;
            std::uint8_t* p = &pic.rgb[(std::size_t(py) * pic.width + std::size_t(px)) * 3];
            p[0] = colour.r;
            p[1] = colour.g;
            p[2] = colour.b;
          }
      }
    x += text_advance(scale);
  }
}

}  // namespace potmap
