#pragma once
// A double as the sum of two floats (hi + lo), about 48 bits of mantissa. The device computes
// differences as (a_hi - b_hi) + (a_lo - b_lo), which keeps float's relative precision in the
// difference even when the coordinates themselves are large.
namespace potmap::detail {

inline void split(double v, float& hi, float& lo) {
  hi = static_cast<float>(v);
  lo = static_cast<float>(v - static_cast<double>(hi));
}

}  // namespace potmap::detail
