// FMA peak kernels (fma_peak.hpp). Each round issues kChains independent multiply-adds
// acc = acc * m + c (m slightly below 1, so the values settle near c / (1 - m): no
// overflow, no denormals). 12 chains cover latency 4 x 2 FMA ports (Zen 3/4, Skylake and
// later) with registers to spare (16 ymm / 32 zmm).
#include "fma_peak.hpp"

#include <cmath>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define HS_BENCH_X86 1
#endif

namespace hs::bench {

namespace {

constexpr int kChains = 12;

template <class T>
double scalar_kernel(std::int64_t rounds) {
  T acc[kChains];
  for (int i = 0; i < kChains; ++i) acc[i] = static_cast<T>(i) * static_cast<T>(1e-3);
  const T m = static_cast<T>(0.999999), c = static_cast<T>(1e-6);
  for (std::int64_t r = 0; r < rounds; ++r)
    for (int i = 0; i < kChains; ++i) acc[i] = std::fma(acc[i], m, c);
  double s = 0.0;
  for (int i = 0; i < kChains; ++i) s += static_cast<double>(acc[i]);
  return s;
}

#ifdef HS_BENCH_X86
// The chains are written out so that the compiler keeps each in its own register.
#define HS_FMA_CHAINS(FMA)                                                                              \
  a0 = FMA(a0, m, c); a1 = FMA(a1, m, c); a2 = FMA(a2, m, c); a3 = FMA(a3, m, c);                       \
  a4 = FMA(a4, m, c); a5 = FMA(a5, m, c); a6 = FMA(a6, m, c); a7 = FMA(a7, m, c);                       \
  a8 = FMA(a8, m, c); a9 = FMA(a9, m, c); a10 = FMA(a10, m, c); a11 = FMA(a11, m, c)

__attribute__((target("avx2,fma"))) double avx2_f32(std::int64_t rounds) {
  const __m256 m = _mm256_set1_ps(0.999999f), c = _mm256_set1_ps(1e-6f);
  __m256 a0 = _mm256_set1_ps(0.0f), a1 = _mm256_set1_ps(0.1f), a2 = _mm256_set1_ps(0.2f), a3 = _mm256_set1_ps(0.3f);
  __m256 a4 = _mm256_set1_ps(0.4f), a5 = _mm256_set1_ps(0.5f), a6 = _mm256_set1_ps(0.6f), a7 = _mm256_set1_ps(0.7f);
  __m256 a8 = _mm256_set1_ps(0.8f), a9 = _mm256_set1_ps(0.9f), a10 = _mm256_set1_ps(1.0f), a11 = _mm256_set1_ps(1.1f);
  for (std::int64_t r = 0; r < rounds; ++r) {
    HS_FMA_CHAINS(_mm256_fmadd_ps);
  }
  const __m256 s = _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(a0, a1), _mm256_add_ps(a2, a3)),
                                 _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(a4, a5), _mm256_add_ps(a6, a7)),
                                               _mm256_add_ps(_mm256_add_ps(a8, a9), _mm256_add_ps(a10, a11))));
  alignas(32) float v[8];
  _mm256_store_ps(v, s);
  double t = 0.0;
  for (float x : v) t += static_cast<double>(x);
  return t;
}

__attribute__((target("avx2,fma"))) double avx2_f64(std::int64_t rounds) {
  const __m256d m = _mm256_set1_pd(0.999999), c = _mm256_set1_pd(1e-6);
  __m256d a0 = _mm256_set1_pd(0.0), a1 = _mm256_set1_pd(0.1), a2 = _mm256_set1_pd(0.2), a3 = _mm256_set1_pd(0.3);
  __m256d a4 = _mm256_set1_pd(0.4), a5 = _mm256_set1_pd(0.5), a6 = _mm256_set1_pd(0.6), a7 = _mm256_set1_pd(0.7);
  __m256d a8 = _mm256_set1_pd(0.8), a9 = _mm256_set1_pd(0.9), a10 = _mm256_set1_pd(1.0), a11 = _mm256_set1_pd(1.1);
  for (std::int64_t r = 0; r < rounds; ++r) {
    HS_FMA_CHAINS(_mm256_fmadd_pd);
  }
  const __m256d s = _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(a0, a1), _mm256_add_pd(a2, a3)),
                                  _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(a4, a5), _mm256_add_pd(a6, a7)),
                                                _mm256_add_pd(_mm256_add_pd(a8, a9), _mm256_add_pd(a10, a11))));
  alignas(32) double v[4];
  _mm256_store_pd(v, s);
  return v[0] + v[1] + v[2] + v[3];
}

__attribute__((target("avx512f"))) double avx512_f32(std::int64_t rounds) {
  const __m512 m = _mm512_set1_ps(0.999999f), c = _mm512_set1_ps(1e-6f);
  __m512 a0 = _mm512_set1_ps(0.0f), a1 = _mm512_set1_ps(0.1f), a2 = _mm512_set1_ps(0.2f), a3 = _mm512_set1_ps(0.3f);
  __m512 a4 = _mm512_set1_ps(0.4f), a5 = _mm512_set1_ps(0.5f), a6 = _mm512_set1_ps(0.6f), a7 = _mm512_set1_ps(0.7f);
  __m512 a8 = _mm512_set1_ps(0.8f), a9 = _mm512_set1_ps(0.9f), a10 = _mm512_set1_ps(1.0f), a11 = _mm512_set1_ps(1.1f);
  for (std::int64_t r = 0; r < rounds; ++r) {
    HS_FMA_CHAINS(_mm512_fmadd_ps);
  }
  const __m512 s = _mm512_add_ps(_mm512_add_ps(_mm512_add_ps(a0, a1), _mm512_add_ps(a2, a3)),
                                 _mm512_add_ps(_mm512_add_ps(_mm512_add_ps(a4, a5), _mm512_add_ps(a6, a7)),
                                               _mm512_add_ps(_mm512_add_ps(a8, a9), _mm512_add_ps(a10, a11))));
  alignas(64) float v[16];  // (not _mm512_reduce_add_ps: GCC 12 warns inside it)
  _mm512_store_ps(v, s);
  double t = 0.0;
  for (float x : v) t += static_cast<double>(x);
  return t;
}

__attribute__((target("avx512f"))) double avx512_f64(std::int64_t rounds) {
  const __m512d m = _mm512_set1_pd(0.999999), c = _mm512_set1_pd(1e-6);
  __m512d a0 = _mm512_set1_pd(0.0), a1 = _mm512_set1_pd(0.1), a2 = _mm512_set1_pd(0.2), a3 = _mm512_set1_pd(0.3);
  __m512d a4 = _mm512_set1_pd(0.4), a5 = _mm512_set1_pd(0.5), a6 = _mm512_set1_pd(0.6), a7 = _mm512_set1_pd(0.7);
  __m512d a8 = _mm512_set1_pd(0.8), a9 = _mm512_set1_pd(0.9), a10 = _mm512_set1_pd(1.0), a11 = _mm512_set1_pd(1.1);
  for (std::int64_t r = 0; r < rounds; ++r) {
    HS_FMA_CHAINS(_mm512_fmadd_pd);
  }
  const __m512d s = _mm512_add_pd(_mm512_add_pd(_mm512_add_pd(a0, a1), _mm512_add_pd(a2, a3)),
                                  _mm512_add_pd(_mm512_add_pd(_mm512_add_pd(a4, a5), _mm512_add_pd(a6, a7)),
                                                _mm512_add_pd(_mm512_add_pd(a8, a9), _mm512_add_pd(a10, a11))));
  alignas(64) double v[8];
  _mm512_store_pd(v, s);
  double t = 0.0;
  for (double x : v) t += x;
  return t;
}
#undef HS_FMA_CHAINS
#endif

}  // namespace

const char* isa_name(FmaIsa isa) {
  switch (isa) {
    case FmaIsa::Scalar: return "scalar";
    case FmaIsa::Avx2: return "avx2";
    case FmaIsa::Avx512: return "avx512";
  }
  return "?";
}

bool fma_supported(FmaIsa isa) {
#ifdef HS_BENCH_X86
  __builtin_cpu_init();
  switch (isa) {
    case FmaIsa::Scalar: return true;
    case FmaIsa::Avx2: return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    case FmaIsa::Avx512: return __builtin_cpu_supports("avx512f");
  }
  return false;
#else
  return isa == FmaIsa::Scalar;
#endif
}

double fma_kernel(FmaIsa isa, FmaType type, std::int64_t rounds) {
  const bool f32 = type == FmaType::F32;
#ifdef HS_BENCH_X86
  if (isa == FmaIsa::Avx2) return f32 ? avx2_f32(rounds) : avx2_f64(rounds);
  if (isa == FmaIsa::Avx512) return f32 ? avx512_f32(rounds) : avx512_f64(rounds);
#endif
  return f32 ? scalar_kernel<float>(rounds) : scalar_kernel<double>(rounds);
}

std::int64_t fma_flops_per_round(FmaIsa isa, FmaType type) {
  const int bytes = isa == FmaIsa::Avx512 ? 64 : isa == FmaIsa::Avx2 ? 32 : (type == FmaType::F32 ? 4 : 8);
  const int lanes = bytes / (type == FmaType::F32 ? 4 : 8);
  return std::int64_t{2} * kChains * lanes;
}

}  // namespace hs::bench
