// exp() and sin() over arrays, written so that compilers vectorise the loops (no calls, no
// branches). The controller uses them for sigmoid and oscillator neurons, where libm's scalar
// exp and sin dominated the tick.
//
// exp: within 2 ulp of the correctly rounded result on [-745, 709.78]; overflows to inf above,
// underflows to 0 below, NaN passes through. sin: fdlibm's kernels after a three-part Cody-Waite
// reduction, within 1e-15 absolute of libm for |x| < 1e6 (beyond, sin_array falls back to
// std::sin). Both are checked against NumPy in tests/brain.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

namespace revolve {

inline std::uint64_t bits_of(double x) {
    std::uint64_t u;
    std::memcpy(&u, &x, sizeof u);
    return u;
}

inline double double_of(std::uint64_t u) {
    double x;
    std::memcpy(&x, &u, sizeof x);
    return x;
}

inline double exp_one(double x) {
    constexpr double kLog2e = 1.4426950408889634;
    constexpr double kLn2Hi = 0x1.62e42fee00000p-1;  // ln 2 with 32 trailing zero bits: n*hi exact
    constexpr double kLn2Lo = 0x1.a39ef35793c76p-33;
    constexpr double kShift = 0x1.8p52;  // adding it rounds to an integer held in the low bits
    const double xc = x > 709.8 ? 709.8 : (x < -745.2 ? -745.2 : x);  // NaN compares false: kept
    const double kd = xc * kLog2e + kShift;
    const double n = kd - kShift;  // round(x / ln 2), in [-1076, 1024]
    const double r = (xc - n * kLn2Hi) - n * kLn2Lo;  // |r| <= ln(2)/2
    // Taylor series to r^13: truncation below 5e-18 relative for |r| <= 0.347.
    double p = 1.0 / 6227020800.0;
    p = p * r + 1.0 / 479001600.0;
    p = p * r + 1.0 / 39916800.0;
    p = p * r + 1.0 / 3628800.0;
    p = p * r + 1.0 / 362880.0;
    p = p * r + 1.0 / 40320.0;
    p = p * r + 1.0 / 5040.0;
    p = p * r + 1.0 / 720.0;
    p = p * r + 1.0 / 120.0;
    p = p * r + 1.0 / 24.0;
    p = p * r + 1.0 / 6.0;
    p = p * r + 0.5;
    p = p * r + 1.0;
    p = p * r + 1.0;
    // 2^n as two normal factors 2^n1 * 2^n2 so that results near overflow and subnormal results
    // are both reached; offset by 1100 so every shift is on a non-negative integer.
    const std::uint64_t m = bits_of(kd) - bits_of(kShift) + 1100;  // n + 1100 >= 24
    const std::uint64_t n1 = (m >> 1) + (1023 - 550);               // biased exponent of 2^(n/2)
    const std::uint64_t n2 = m - (m >> 1) + (1023 - 550);
    const double y = p * double_of(n1 << 52) * double_of(n2 << 52);
    return x > 709.8 ? x * 1e308 : y;  // inf above the range, NaN stays NaN (NaN * 1e308)
}

// sin(x) for |x| < 1e6 (larger or non-finite x: garbage, which sin_array replaces).
inline double sin_one(double x) {
    constexpr double kTwoOverPi = 6.36619772367581382433e-01;
    constexpr double kPio2_1 = 1.57079632673412561417e+00;   // first 33 bits of pi/2
    constexpr double kPio2_2 = 6.07710050630396597660e-11;   // next 33 bits
    constexpr double kPio2_2t = 2.02226624879595063154e-21;  // pi/2 - kPio2_1 - kPio2_2
    constexpr double kShift = 0x1.8p52;
    const double kd = x * kTwoOverPi + kShift;
    const double k = kd - kShift;  // nearest multiple of pi/2, |k| < 2^20: k * kPio2_* exact
    const double r = ((x - k * kPio2_1) - k * kPio2_2) - k * kPio2_2t;  // |r| <= pi/4 (a bit more)
    const double z = r * r;
    // fdlibm __kernel_sin and __kernel_cos with a zero tail.
    const double sr = 8.33333333332248946124e-03 +
                      z * (-1.98412698298579493134e-04 +
                           z * (2.75573137070700676789e-06 +
                                z * (-2.50507602534068634195e-08 + z * 1.58969099521155010221e-10)));
    const double sin_r = r + z * r * (-1.66666666666666324348e-01 + z * sr);
    const double cr =
        z * (4.16666666666666019037e-02 +
             z * (-1.38888888888741095749e-03 +
                  z * (2.48015872894767294178e-05 +
                       z * (-2.75573143513906633035e-07 +
                            z * (2.08757232129817482790e-09 + z * -1.13596475577881948265e-11)))));
    const double hz = 0.5 * z;
    const double w = 1.0 - hz;
    const double cos_r = w + (((1.0 - w) - hz) + z * cr);
    const std::uint64_t q = bits_of(kd) - bits_of(kShift);  // k mod 4 in the low bits
    const double v = (q & 1) ? cos_r : sin_r;
    return (q & 2) ? -v : v;
}

// out[i] = exp(x[i]) and out[i] = sin(x[i]) for i < n; out may alias x. Defined in
// batch_controller.cpp, where they are compiled for AVX2 as well as the baseline instruction set
// when the compiler supports it.
void exp_array(const double* x, double* out, std::size_t n);
void sin_array(const double* x, double* out, std::size_t n);

}  // namespace revolve
