// e^x and e^x - 1 in double precision (and ln(1 + x) by its series near 0), written once for one double
// and for the lanes of a GCC vector of doubles: the linearized chamber step takes them in both forms
// (chamber.cc, one chamber; chamber_batch.cc, four in vector lanes), and they agree bit for bit.
//
// The project's own evaluation, by the classic method: Cody and Waite's reduction
// x = k ln 2 + r with |r| <= ln(2)/2 (ln 2 in two parts, the second below the first's last bit,
// as in fdlibm's exp), Taylor's series of e^r - 1 to r^13/13! (the first term left out is below
// 4e-18 |r|), and 2^k from the exponent's bits. Within 2 ulp of the C library's exp and expm1
// (tests/chamber_test) on [-708, 709]; e^x = +inf above 709 (the C library's overflows at 709.78) and
// 0 below -708 (no subnormal results), e^x - 1 = -1 there; NaN stays NaN.
#ifndef PNEUMATIC_EXPONENTIAL_H_
#define PNEUMATIC_EXPONENTIAL_H_

#include <cstdint>
#include <cstring>
#include <limits>

namespace pneumatic {
namespace exponential {

// what the evaluation needs of its number type: the bits of a double and back, and a select
inline std::int64_t Bits(double x) {
  std::int64_t bits;
  std::memcpy(&bits, &x, sizeof x);
  return bits;
}
inline double FromBits(std::int64_t bits) {
  double x;
  std::memcpy(&x, &bits, sizeof x);
  return x;
}
inline double Choose(bool m, double a, double b) { return m ? a : b; }
// GCC vectors of doubles: a cast between vector types of one size reinterprets the bits; masks are what
// comparisons give, all ones or all zeros in each lane
template <typename Lanes>
[[gnu::always_inline]] inline auto Bits(Lanes x) {
  typedef std::int64_t Mask __attribute__((vector_size(sizeof(Lanes))));
  return (Mask)x;
}
template <typename Mask>
[[gnu::always_inline]] inline auto FromBits(Mask bits) {
  typedef double Lanes __attribute__((vector_size(sizeof(Mask))));
  return (Lanes)bits;
}
template <typename Mask, typename Lanes>
[[gnu::always_inline]] inline Lanes Choose(Mask m, Lanes a, Lanes b) {
  return (Lanes)(((Mask)a & m) | ((Mask)b & ~m));
}
// the bits of the double 2^(biased - 1023), biased in [1, 2046]: shifted as unsigned, so that a NaN's
// garbage shifts without overflow
inline std::int64_t ExponentBits(std::int64_t biased) {
  return static_cast<std::int64_t>(static_cast<std::uint64_t>(biased) << 52);
}
template <typename Mask>
[[gnu::always_inline]] inline Mask ExponentBits(Mask biased) {
  typedef std::uint64_t Unsigned __attribute__((vector_size(sizeof(Mask))));
  return (Mask)((Unsigned)biased << 52);
}

constexpr double kLargest = 709.0;   // e^x is below 2^1023 (k <= 1023) up to it
constexpr double kSmallest = -708.0;           // e^x is normal above it
constexpr double kInverseLn2 = 1.44269504088896338700e+00;
constexpr double kLn2High = 6.93147180369123816490e-01;  // 32 bits: k kLn2High is exact for |k| < 2^20
constexpr double kLn2Low = 1.90821492927058770002e-10;
constexpr double kShifter = 0x1.8p52;  // adding it rounds to an integer, held in the low bits

// e^x = 2^k (1 + p), p = e^r - 1: returns p, *scale = 2^k (x in [kSmallest, kLargest])
template <typename T>
[[gnu::always_inline]] inline T Reduced(T x, T* scale) {
  T shifted = x * kInverseLn2 + kShifter;
  T k = shifted - kShifter;
  T r = (x - k * kLn2High) - k * kLn2Low;
  // e^r - 1 = r + r^2 (1/2! + r (1/3! + ... + r / 13!))
  T q = 1.0 / 2 + r * (1.0 / 6 + r * (1.0 / 24 + r * (1.0 / 120 + r * (1.0 / 720 + r * (1.0 / 5040 + r * (1.0 / 40320 +
        r * (1.0 / 362880 + r * (1.0 / 3628800 + r * (1.0 / 39916800 + r * (1.0 / 479001600 +
        r * (1.0 / 6227020800.0)))))))))));
  auto k_bits = Bits(shifted) - Bits(kShifter);  // k, an integer
  *scale = FromBits(ExponentBits(k_bits + 1023));
  return r + r * r * q;
}

template <typename T>
[[gnu::always_inline]] inline T Exp(T x) {
  T inside = Choose(x < kSmallest, T{} + kSmallest, Choose(x > kLargest, T{} + kLargest, x));
  T scale;
  T p = Reduced(inside, &scale);
  T e = scale + scale * p;
  return Choose(x > kLargest, T{} + std::numeric_limits<double>::infinity(), Choose(x < kSmallest, T{} + 0.0, e));
}

// ln(1 + x) by its series x - x^2/2 + ... - x^10/10 in Horner's form, for |x| <= kLog1pSeriesLimit (the
// first term left out, x^11/11, is below 1e-19 |x| there): within 2 ulp of std::log1p (tests/chamber_test).
// Log1p (chamber.h) takes std::log1p beyond.
constexpr double kLog1pSeriesLimit = 1.0 / 64;
template <typename T>
[[gnu::always_inline]] inline T Log1pSeries(T x) {
  return x * (1 - x * (1.0 / 2 - x * (1.0 / 3 - x * (1.0 / 4 - x * (1.0 / 5 - x * (1.0 / 6 - x * (1.0 / 7 -
         x * (1.0 / 8 - x * (1.0 / 9 - x / 10)))))))));
}

template <typename T>
[[gnu::always_inline]] inline T Expm1(T x) {
  T inside = Choose(x < kSmallest, T{} + kSmallest, Choose(x > kLargest, T{} + kLargest, x));
  T scale;
  T p = Reduced(inside, &scale);
  // 2^k p + (2^k - 1): the second term is exact for the k that matter (|k| <= 53)
  T e = scale * p + (scale - 1);
  return Choose(x > kLargest, T{} + std::numeric_limits<double>::infinity(), Choose(x < kSmallest, T{} - 1.0, e));
}

}  // namespace exponential
}  // namespace pneumatic

#endif  // PNEUMATIC_EXPONENTIAL_H_
