// exp() over an array, written so that compilers vectorise the loop (no calls, no branches).
//
// Accuracy: within 2 ulp of the correctly rounded result on [-745, 709.78] (tested in
// tests/brain against NumPy); overflows to inf above, underflows to 0 below, NaN passes through.
// The controller uses it for sigmoid neurons, where libm's scalar exp dominated the tick.
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

// out[i] = exp(x[i]) for i < n; out may alias x. Defined in batch_controller.cpp, where it is
// compiled for AVX2 as well as the baseline instruction set when the compiler supports it.
void exp_array(const double* x, double* out, std::size_t n);

}  // namespace revolve
